"""Generates python/hpctl/_effect_params.py from the core's effect tables.

Each effect's parameters are declared once, in hp-core (``effect_params!``
in ``crates/hp-core/src/unit.rs``: fields, docs, valid ranges, defaults);
the bindings export the tables as ``hpctl._core.EFFECT_PARAMETERS``. This
writes the Python side from them: one frozen dataclass per effect (the
public ``hpctl.Friction``, ``hpctl.Sensor``, ... with the core's field
names, docs and defaults), the ``Effects`` dataclass of all of them, and the
TypedDicts of their dict form for the stub. tests/test_effects_registry.py
checks that the checked-in file is what this writes.

    python scripts/gen_effect_params.py > python/hpctl/_effect_params.py
"""

from __future__ import annotations

import textwrap

from hpctl import _core


def _doc(text: str, indent: str) -> list[str]:
    lines = textwrap.wrap(" ".join(text.split()), 76 - len(indent))
    if len(lines) == 1:
        return [f'{indent}"""{lines[0]}"""']
    return [f'{indent}"""{lines[0]}', *(f"{indent}{x}" for x in lines[1:]), f'{indent}"""']


def source() -> str:
    tables = _core.EFFECT_PARAMETERS
    out = [
        '"""The effects\' parameter classes, generated from the core\'s tables',
        "(hp-core ``effect_params!``, exported as ``_core.EFFECT_PARAMETERS``) by",
        "``python scripts/gen_effect_params.py``; do not edit by hand.",
        "",
        "Public through :mod:`hpctl.model.unit` (``hpctl.Friction``, ...).",
        '"""',
        "",
        "from __future__ import annotations",
        "",
        "from dataclasses import dataclass",
        "from typing import TypedDict",
    ]
    for t in tables:
        out += ["", "", "@dataclass(frozen=True)", f"class {t['name']}:"]
        out += _doc(t["doc"], "    ")
        out.append("")
        fields = t["fields"]
        defaults = [f["default"] is not None for f in fields]
        if defaults != sorted(defaults):
            raise SystemExit(f"{t['name']}: declare the required fields before those with defaults (a dataclass's rule)")
        for f in fields:
            lo, hi = f["range"]
            out += [f"    #: {line}" for line in textwrap.wrap(" ".join(f["doc"].split()) + f" Valid: [{lo:g}, {hi:g}] (``{f['parameter']}``).", 72)]
            out.append(f"    {f['field']}: float" + ("" if f["default"] is None else f" = {f['default']!r}"))
    out += ["", "", "@dataclass(frozen=True)", "class Effects:", '    """Optional model terms; ``None`` means the effect is absent."""', ""]
    out += [f"    {t['key']}: {t['name']} | None = None" for t in tables]
    out += ["", "", "#: Each effect's parameter class by its key in :class:`Effects`.", "EFFECT_TYPES: dict[str, type] = {"]
    out += [f'    "{t["key"]}": {t["name"]},' for t in tables]
    out += ["}"]
    out += ["", "", "# --- the dict form the core reads (hpctl._coretypes.UnitDict.effects) ---"]
    for t in tables:
        out += ["", "", f"class {t['name']}Dict(TypedDict):"]
        out += [f"    {f['field']}: float" for f in t["fields"]]
    out += ["", "", "class EffectsDict(TypedDict, total=False):"]
    out += [f"    {t['key']}: {t['name']}Dict" for t in tables]
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    print(source(), end="")
