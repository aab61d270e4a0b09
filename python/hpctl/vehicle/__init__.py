"""Whole vehicles on the unit: models (:mod:`~hpctl.vehicle.model`), routes
and drivers (:mod:`~hpctl.vehicle.route`), ISO 2631-1 comfort
(:mod:`~hpctl.vehicle.iso2631`) and the section metrics
(:mod:`~hpctl.vehicle.metrics`), the passive-versus-semi-active comparison
(:mod:`~hpctl.vehicle.comparison`) and the controller's tuning
(:mod:`~hpctl.vehicle.tuning`). The dynamics run in Rust (``hp-vehicle``)."""
