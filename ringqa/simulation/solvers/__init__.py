"""Solvers: quasi-static load stepping and implicit dynamics (one Newton kernel for both)."""
