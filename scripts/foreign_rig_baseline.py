"""Baseline of hpctl on the foreign rig (a comparison, not a test).

For each effect (and none), draws a case on the foreign rig
(tests/foreign_rig), writes its records, then runs

    hpctl diagnose RECORDS --model seed --json      (what is named, in what order)
    hpctl fit RECORDS --model seed,EFFECT --json    (the right effect declared)

and records the verdict, the effects found, the residual against hpctl's
own noise estimate and against the true noise (truth.json), the fitted
parameters against the truth, and the wall time. Writes baseline.json and
baseline.md into --out. Runs one case at a time (the machine is shared).

    python scripts/foreign_rig_baseline.py --out /tmp/foreign-baseline [--effects none,friction] [--seeds 1,2] [--no-fit] [--flexible]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.foreign_rig import EFFECTS, LIBRARY_EFFECTS, generate  # noqa: E402

SIGMA_KEY = {"force_n": "force_n", "p_gas_pa": "p_pa", "p_gas2_pa": "p_pa", "body_disp_m": "disp_m"}


def run(cmd: list[str], timeout_s: float) -> tuple[dict[str, Any] | None, float, str]:
    start = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return None, time.perf_counter() - start, f"timeout after {timeout_s:.0f} s"
    took = time.perf_counter() - start
    if p.returncode != 0:
        return None, took, f"exit {p.returncode}: {(p.stderr or p.stdout).strip()[-400:]}"
    try:
        return json.loads(p.stdout), took, ""
    except json.JSONDecodeError:
        return None, took, f"no JSON: {p.stdout[-300:]}"


def true_noise_ratios(channels: list[dict[str, Any]], truth: dict[str, Any]) -> dict[str, float]:
    """Residual RMS over the true noise sigma, per (record, channel): the
    median and the worst, and the pooled RMS ratio."""
    r = []
    for c in channels:
        key = SIGMA_KEY.get(c["channel"])
        if key is None:
            continue
        r.append(c["rms"] / truth["noise"][key]["sigma"])
    if not r:
        return {}
    r.sort()
    return {"median": r[len(r) // 2], "max": r[-1], "pooled": (sum(x * x for x in r) / len(r)) ** 0.5}


def params_vs_truth(params: dict[str, float], stderr: dict[str, float], truth: dict[str, Any]) -> dict[str, dict[str, float]]:
    out = {}
    for k, v in truth["hpctl_params"].items():
        if k in params:
            out[k] = {"true": v, "fitted": params[k], "stderr": stderr.get(k, float("nan")), "rel_error": params[k] / v - 1 if v else float("nan")}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--effects", default="none," + ",".join(EFFECTS))
    ap.add_argument("--seeds", default="1")
    ap.add_argument("--program", default="effect")
    ap.add_argument("--timeout-s", type=float, default=900.0)
    ap.add_argument("--no-fit", action="store_true", help="skip the fit with the right effect declared")
    ap.add_argument("--flexible", action="store_true", help="diagnose and fit with --flexible (the damper characteristic identified)")
    a = ap.parse_args()
    flexible = ["--flexible"] if a.flexible else []
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    results_path = out / "baseline.json"
    results: list[dict[str, Any]] = json.loads(results_path.read_text()) if results_path.exists() else []
    done = {(r["effect"], r["seed"], r["program"]) for r in results}
    for seed in (int(s) for s in a.seeds.split(",")):
        for effect in a.effects.split(","):
            if (effect, seed, a.program) in done:
                continue
            eff = None if effect == "none" else effect
            case_dir = out / f"{effect}-{seed}-{a.program}"
            t0 = time.perf_counter()
            g = generate(eff, seed, out=case_dir / "records", program=a.program) if not (case_dir / "records" / "truth.json").exists() else None
            gen_s = time.perf_counter() - t0
            truth = json.loads((case_dir / "records" / "truth.json").read_text())
            rec_s = sum(float(open(p).read().rsplit("\n", 2)[-2].split(",")[0]) for p in (case_dir / "records").glob("*.csv"))
            row: dict[str, Any] = {"effect": effect, "seed": seed, "program": a.program, "records": truth["records"], "record_seconds": rec_s,
                                   "generation_s": truth["generation_s"] if g is not None else gen_s, "truth": truth["hpctl_params"],
                                   "noise_sigma": {k: v["sigma"] for k, v in truth["noise"].items() if isinstance(v, dict)}}
            print(f"== {effect} seed {seed}: {len(truth['records'])} records, {rec_s:.0f} s of rig data, generated in {row['generation_s']:.1f} s", flush=True)
            d, took, err = run(["hpctl", "diagnose", str(case_dir / "records"), "--model", "seed", "--json", "-q", "--out", str(case_dir / "diagnose")] + flexible, a.timeout_s)
            row["diagnose_s"] = round(took, 1)
            if d is None:
                row["diagnose_error"] = err
            else:
                row["verdict"] = d["verdict"]
                row["structure_remains"] = d.get("structure_remains")
                row["remaining_structure"] = d.get("remaining_structure", {}).get("text")
                row["found"] = [e["effect"] for e in d["effects"]]
                row["rms_ratio_before"] = d["error_before"]["rms_ratio"]
                row["rms_ratio_after"] = d["error_after"]["rms_ratio"]
                row["steps"] = [(e["effect"], round(e["rms_ratio_before"], 2), round(e["rms_ratio_after"], 2)) for e in d["effects"]]
                row["true_noise_before"] = true_noise_ratios(d["error_before"]["channels"], truth)
                row["true_noise_after"] = true_noise_ratios(d["error_after"]["channels"], truth)
                row["diagnose_params"] = params_vs_truth(d["final_params"], d["final_stderr"], truth)
                row["diagnose_other_params"] = {k: v for k, v in d["final_params"].items() if k in ("charge_scale", "damper_gain", "polytropic_exponent")}
            print(f"   diagnose: {took:.0f} s {row.get('verdict', err)} found={row.get('found')} rms {row.get('rms_ratio_before')} -> {row.get('rms_ratio_after')}", flush=True)
            if not a.no_fit and eff in LIBRARY_EFFECTS:
                f, took, err = run(["hpctl", "fit", str(case_dir / "records"), "--model", f"seed,{eff}", "--json", "-q", "--out", str(case_dir / "fit")] + flexible, a.timeout_s)
                row["fit_s"] = round(took, 1)
                if f is None:
                    row["fit_error"] = err
                else:
                    row["fit_rms_ratio"] = f["rms_ratio"]
                    row["fit_true_noise"] = true_noise_ratios(f["channels"], truth)
                    row["fit_params"] = params_vs_truth(f["params"], f["stderr"], truth)
                    row["fit_other_params"] = {k: v for k, v in f["params"].items() if k in ("charge_scale", "damper_gain")}
                print(f"   fit seed,{eff}: {took:.0f} s rms {row.get('fit_rms_ratio', err)}", flush=True)
            results.append(row)
            results_path.write_text(json.dumps(results, indent=1) + "\n")
    (out / "baseline.md").write_text(markdown(results))
    return 0


def _worst(r: dict[str, Any]) -> str:
    """The first place of the remaining-structure text (or at the noise)."""
    text = r.get("remaining_structure") or "-"
    head, _, places = text.partition(": ")
    # Places are joined by "; " before the next "record/channel".
    return (re.split(r"; (?=[\w.]+/)", places)[0] if places else head).replace("|", "/")


def markdown(results: list[dict[str, Any]]) -> str:
    lines = ["| effect | seed | rig data | diagnose | verdict | found (rms ratio before -> after) | after / true noise (pooled, worst) | fit seed+effect: rms ratio, params vs truth | fit time | where structure remains (worst place) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        steps = ", ".join(f"{e} ({b} -> {a_})" for e, b, a_ in r.get("steps", [])) or "-"
        tn = r.get("true_noise_after", {})
        fitp = "; ".join(f"{k} {v['rel_error']:+.0%} (+-{abs(v['stderr'] / v['true']):.0%})" for k, v in r.get("fit_params", {}).items() if k != "tau_s")
        fit = f"{r['fit_rms_ratio']:.2f}; {fitp}" if "fit_rms_ratio" in r else r.get("fit_error", "-")
        verdict = r.get("verdict", r.get("diagnose_error", ""))
        before = f"{r['rms_ratio_before']:.1f} -> " if "rms_ratio_before" in r else ""
        lines.append(f"| {r['effect']} | {r['seed']} | {len(r['records'])} rec, {r['record_seconds']:.0f} s | {r['diagnose_s']:.0f} s | {verdict} | {before}{steps} | "
                     f"{tn.get('pooled', float('nan')):.1f}, {tn.get('max', float('nan')):.1f} | {fit} | {r.get('fit_s', '-')} | {_worst(r)} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
