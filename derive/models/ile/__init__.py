"""The instantaneous leg extension (ILE) model: its facts (:mod:`.model`) and its closed forms
(:mod:`.closed_form`, whose :func:`derive` the code generator calls)."""

from derive.models.ile.closed_form import *  # noqa: F403
from derive.models.ile.closed_form import _closest_to_apex_cos  # noqa: F401
from derive.models.ile.model import *  # noqa: F403
