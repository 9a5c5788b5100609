"""``formsync derive`` (being written)."""
from __future__ import annotations

def add_parser(sub):
    p = sub.add_parser("derive", help="derive the closed loop and Lyapunov conditions")
    p.set_defaults(func=lambda a: 0)
