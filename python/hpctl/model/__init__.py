"""What a unit *is*: its parameters (:mod:`hpctl.model.unit`) and the
switchable effects a calibration may add (:mod:`hpctl.model.effects`).

Depends only on the Rust core and :mod:`hpctl.errors`.
"""
