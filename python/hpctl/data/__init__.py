"""Data in and out: rig records and their schema
(:mod:`hpctl.data.records`, format: ``docs/rig-data-format.md``).

Package data lives here too: the CAN database (:data:`DBC_PATH`, the
single source of truth for every frame), the rig-record format's
specification (:data:`RECORD_FORMAT_PATH`) and the demo's bundled records
(``demo/``).
"""

from __future__ import annotations

from pathlib import Path

#: The CAN database of the ECU (``hpctl.dbc``), shipped inside the package.
DBC_PATH: Path = Path(__file__).resolve().parent / "hpctl.dbc"
#: The specification of the rig-record format (Markdown).
RECORD_FORMAT_PATH: Path = Path(__file__).resolve().parent / "rig-data-format.md"
#: The bundled rig records of ``hpctl demo``.
DEMO_DIR: Path = Path(__file__).resolve().parent / "demo"
