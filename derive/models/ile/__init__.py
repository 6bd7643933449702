"""The instantaneous leg extension (ILE) model: its facts (:mod:`.model`) and its closed forms,
one module per idea: the phases and resets (:mod:`.phases`), the stride map and its fixed
point (:mod:`.stride_map`), the energy balance (:mod:`.energy`), the apex and contact bounds
(:mod:`.bounds`), the step timing (:mod:`.timing`), the existence conditions
(:mod:`.existence`), and :mod:`.closed_form`, whose :func:`derive` the code generator calls."""

from derive.models.ile.bounds import *  # noqa: F403
from derive.models.ile.closed_form import *  # noqa: F403
from derive.models.ile.energy import *  # noqa: F403
from derive.models.ile.existence import *  # noqa: F403
from derive.models.ile.model import *  # noqa: F403
from derive.models.ile.phases import *  # noqa: F403
from derive.models.ile.stride_map import *  # noqa: F403
from derive.models.ile.timing import *  # noqa: F403
