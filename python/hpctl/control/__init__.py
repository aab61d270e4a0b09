"""The controller as flown on the ECU (:mod:`hpctl.control.controller`),
roads (:mod:`hpctl.control.road`) and the controller in closed loop with
the plant (:mod:`hpctl.control.closed_loop`).

Depends on :mod:`hpctl.sim` and :mod:`hpctl.model`.
"""
