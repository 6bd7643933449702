"""Errors the runtime raises; the CLI prints their message as one line and exits 2 (or 3)."""


class VswInputError(ValueError):
    """Bad input: the message names the parameter and the violated condition (with its equation)."""


class ModelConditionError(VswInputError):
    """A model condition fails (e.g. no fixed point); the message cites the equation."""


class ConvergenceError(RuntimeError):
    """A numerical solver stopped without converging or returned a non-finite result."""


class InfeasibleError(RuntimeError):
    """A design request whose constraints cannot hold together."""


class SlowRouteWarning(UserWarning):
    """The compiled batch simulator could not be built (no compiler, a bad ``CC``, an
    unusable cache): the walks take the SciPy route, same classes, about 300 times slower.
    The CLI prints it once on stderr as ``vsw: warning: ...``."""


class CacheWarning(SlowRouteWarning):
    """A cache entry not used because it is not what it claims (damaged, altered, fields
    out of range, a kept gait that is no gait): the work is done again, the result as a new
    run's, only slower. A SlowRouteWarning so that the CLI prints it the same way, once, as
    one line ``vsw: warning: ...``."""
