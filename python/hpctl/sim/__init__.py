"""Running the plant: rigs, motions and runs (:mod:`hpctl.sim.run`), the
seed's experiments (:mod:`hpctl.sim.experiments`), test metrics
(:mod:`hpctl.sim.metrics`) and parameter sweeps (:mod:`hpctl.sim.sweep`).

Depends on :mod:`hpctl.model` and :mod:`hpctl.data`.
"""
