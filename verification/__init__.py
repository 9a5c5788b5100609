"""The shipped published cases and report scripts (installed as ``formsync_design.verification``)."""
