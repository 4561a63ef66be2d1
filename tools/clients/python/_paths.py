"""Puts the generated LCM types on sys.path when PYTHONPATH does not already provide them:
$MOTION_LCMTYPES_PYTHON, else <repo>/build/lcmtypes/python."""
import os
import sys


def add_lcmtypes() -> None:
    try:
        import motionlcm  # noqa: F401
        return
    except ImportError:
        pass
    repo = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
    for candidate in (os.environ.get("MOTION_LCMTYPES_PYTHON"), os.path.join(repo, "build", "lcmtypes", "python")):
        if candidate and os.path.isdir(os.path.join(candidate, "motionlcm")):
            sys.path.insert(0, candidate)
            return
