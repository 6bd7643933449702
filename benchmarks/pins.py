"""The earlier commits some benchmark cases run side by side with the current code: each
pin is a case's input (a checkout of it, or its files by ``git show``), and results.md
names the baseline it measured."""

DESIGN_BEFORE = "39d527c"
"""The commit whose vsw/synthesis/design.py case 8 compares with (before the design was
rewritten)."""
DERIVE_BEFORE = "5e02f11"
"""The tree case 7 derives side by side with this one: the last whose impulse at an impact
was solved by one symbolic solve inside another (its level compass gait took minutes)."""
DERIVE_COSTS_BEFORE = "24e9efe"
"""The tree beside which case 7's rows noted 'against 24e9efe' were measured, apart from
the rest of the case: the derivation of every model, the heaviest models alone,
``derive --check`` and the user's model file, each process alternating with the same
command in a checkout of this commit (medians)."""
BATCH_BEFORE = "cc98831"
"""The commit before the batch simulator's C was rewritten in lanes (case 15 runs its table
and integrator side by side with the current ones)."""
BATCH_BEFORE_FLAGS = (
    ["-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno", "-lm"],
    ["-O2", "-ffp-contract=off", "-lm"],
)
"""vsw/dynamics/batch.py's flags at BATCH_BEFORE."""
THREADS_BEFORE = "9fcf285"
"""The commit before BLAS's threads were bounded by the walks' (case 15 with ``--against``
and no REF times its walks in a checkout of it, beside this tree's)."""
