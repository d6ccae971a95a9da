"""Needle insertion forces in S-shaped channels (the paper's second model; docs/needle.md)."""
