"""The rod drives' section of the calibration report: each named drive effect in one plain sentence, and the
held-out joint position errors nominal -> calibrated (rods.identify's block) as markdown."""
from __future__ import annotations

from . import effect_gain
from .rods import EFFECT_OF, HORIZONS


def describe(effect: dict) -> str:
    """One plain sentence for the report."""
    p = effect["params"]
    narrowed = any(k in p for k in ("team", "rod", "axis"))
    drives = "The " + " ".join(str(p[k]) for k in ("team", "rod", "axis") if k in p) + " drive" if narrowed else "Every drive"
    where = " of the " + drives[4:] if narrowed else " of every drive"
    if effect["name"] == "rod_latency":
        return (f"{drives} acts {p['delay'] * 1000:.0f} ms after a command arrives (dead time). Modelled by delaying the "
                "commands TableSimulation gives its drives (foos_sim.drive_limits).")
    parts = [f"{p['slide']:.3g} m/s{'^2' if 'acceleration' in effect['name'] else ''} sliding" if "slide" in p else "",
             f"{p['rotate']:.3g} rad/s{'^2' if 'acceleration' in effect['name'] else ''} turning" if "rotate" in p else ""]
    what = "speed" if effect["name"] == "rod_speed_limit" else "acceleration"
    return (f"The {what}{where} is limited to {' and '.join(x for x in parts if x)}. Modelled by limiting the servo's "
            "target (foos_sim.drive_limits), or on jerk-limited drives their trajectory generators' (foos_sim.drive_profiles).")


def markdown(block: dict, effects: list[dict]) -> str:
    """The report's rods section."""
    out = ["", "## The rod drives", ""]
    named = [e for e in effects if e["name"] in EFFECT_OF.values()]
    out += [f"- **{e['name']}** {e['params']}: {describe(e)} (held-out evidence "
            f"{e['evidence']['held_out_error_drop_noise_variances']} noise variances over {e['evidence']['drives_named']} drive(s); "
            f"held-out gain {effect_gain.describe(e['evidence'].get('gain'))})"
            for e in named] or ["Nothing: the nominal drives explain the joint states."]
    out += ["", "Joint position error on held-out stretches (median, 95 % bootstrap interval), nominal -> calibrated:", "",
            "| axis | horizon | nominal | calibrated |", "|---|---|---|---|"]
    b, c = block["baseline"], block["calibrated"]
    for axis, unit in (("slide", "mm"), ("rotate", "deg")):
        for horizon in HORIZONS:
            key = f"{axis}_median_error_{unit}_{horizon:g}s".replace(".", "_")
            ci = key.replace("median_error", "ci95")
            out.append(f"| {axis} ({unit}) | {horizon:g} s | {b.get(key)} {b.get(ci, '')} | {c.get(key)} {c.get(ci, '')} |")
    # The drives an effect names one by one: their own errors, which the medians over all 16 drives hide.
    own = {name for e in named if e["params"].get("team") for name in e["evidence"].get("per_drive", {})}
    rows = [(name, gain) for name, gain in (block.get("per_drive_error_0_25s") or {}).items() if name in own]
    if rows:
        out += ["", "The drives with an effect of their own, error 0.25 s ahead (median over starts), nominal -> calibrated:", ""]
        out += [f"- {name}: {g['baseline']} -> {g['calibrated']} {g['unit']}" for name, g in rows]
    return "\n".join(out) + "\n"
