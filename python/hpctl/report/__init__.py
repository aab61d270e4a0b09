"""Reports for people: plots (:mod:`hpctl.report.plots`,
:mod:`hpctl.report.closed_loop`) and the calibration reports
(:mod:`hpctl.report.calibration`).

Depends on the layers it reports on; nothing but :mod:`hpctl.cli` depends
on it.
"""
