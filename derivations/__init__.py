"""The shipped design specifications (installed as ``formsync_design.derivations``)."""
