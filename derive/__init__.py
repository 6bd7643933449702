"""Symbolic derivation engine: sympy derives hybrid walking models from first principles.

``python -m derive`` writes the numeric code into ``generated/``; ``--check`` verifies it.
"""
