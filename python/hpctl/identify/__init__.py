"""Identification from measurements: fitting the model to rig records
(:mod:`hpctl.identify.fit`), finding what it lacks
(:mod:`hpctl.identify.diagnose`), and a virtual test rig to check both
(:mod:`hpctl.identify.virtual_rig`).

Depends on :mod:`hpctl.sim`, :mod:`hpctl.model` and :mod:`hpctl.data`.
"""
