"""The ILE model's extension of the runtime: its closed forms behind the model interface.

:class:`~vsw.models.ile.model.IleModel` is the ILE as a :class:`vsw.dynamics.hybrid.HybridModel`
whose answers come from the paper's closed forms (``generated.ile``): the fixed point (10),
its eigenvalue (19), the existence conditions (12)-(17) and the energies (18)-(23). The
modules beside it are those closed forms' own tools: :mod:`.analysis` (vectorised over
parameter sets), :mod:`.basin` (Fig. 9), :mod:`.sweep`, :mod:`.design` (IPOPT),
:mod:`.kernels` (compiled batch loops), :mod:`.simulate` (its time-domain check),
:mod:`.plots` and :mod:`.explore` (the page).
"""
