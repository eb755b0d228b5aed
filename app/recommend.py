"""Per-scene recommendations from measured cost and quality, with the rule written out."""
from __future__ import annotations

# the study's conclusions (section 5.0) for the archetype each built-in scene stands for
STUDY = {
    "arcade": ("Arcade (sparse indoor)", "RT ambient occlusion"),
    "street": ("Bistro exterior (urban outdoor)", "RT reflections + RT global illumination"),
    "cafe": ("Bistro interior (cluttered indoor)", "RT shadows + RT ambient occlusion (reflections optional)"),
    "park": ("Emerald Square (sparse outdoor)", "RT shadows (reflections only with water)"),
    "temple": ("Sun Temple (sparse indoor)", "RT ambient occlusion"),
}
# the same conclusions as sets of effects (EFFECT_NAME's keys), optional ones left out
STUDY_EFFECTS = {"arcade": {"ao"}, "street": {"reflections", "gi"}, "cafe": {"shadows", "ao"}, "park": {"shadows"},
                 "temple": {"ao"}}
# the study's average frame rates (section 4, 1920x1080, 60 s each; Falcor on an NVIDIA Ampere GPU): Arcade,
# Bistro Exterior, Bistro Interior, Emerald Square, Sun Temple; None where the study has N/A
_FPS = {"forward": (762, 258, None, 90, 410), "reflections": (962, 490, 620, 148, 614),
        "shadows_all": (817, 487, None, 135, 125), "shadows_one": (947, 486, None, 135, 755),
        "gi_1": (491, 171, None, 78, 331), "gi_4": (168, 55, None, 22, 115), "gi_shadows": (490, 165, None, 61, 316),
        "ao_1": (705, 399, 505, 163, 595), "ao_4": (506, 250, 313, 103, 389)}
STUDY_FPS = {cfg: dict(zip(("arcade", "street", "cafe", "park", "temple"), fps, strict=True))
             for cfg, fps in _FPS.items()}
EFFECT_OF = {"reflections": "reflections", "shadows_all": "shadows", "shadows_one": "shadows", "gi_1": "gi",
             "gi_4": "gi", "gi_shadows": "gi", "ao_1": "ao", "ao_4": "ao"}
EFFECT_NAME = {"reflections": "RT reflections", "shadows": "RT shadows", "gi": "RT global illumination",
               "ao": "RT ambient occlusion"}
MIN_GAIN = 0.005  # mean-FLIP reduction below this is not a visible improvement


def rule_text(budget_ms: float | None) -> str:
    budget = f"the extra frame time fits a budget of {budget_ms:g} ms" if budget_ms else "no frame-time budget"
    return (f"For each effect (shadows, reflections, GI, AO) take its configuration with the best quality gain per "
            f"extra millisecond, where quality gain = mean FLIP of the forward baseline minus mean FLIP of the "
            f"forward renderer with that effect ray traced (accumulated, against the converged reference path "
            f"tracer) and extra milliseconds = its frame time minus the forward frame time. Keep effects whose gain "
            f"is at least {MIN_GAIN}; add them in order of gain per millisecond while {budget}.")


def recommend(rows: list[dict], budget_ms: float | None = None) -> dict:
    """rows: result rows of one scene (config, frame_ms.mean, quality.gain). Returns the pick."""
    by_config = {r["config"]: r for r in rows}
    forward = by_config.get("forward")
    base_ms = forward["frame_ms"]["mean"] if forward else 0.0
    best: dict[str, dict] = {}
    for r in rows:
        effect = EFFECT_OF.get(r["config"])
        q = r.get("quality") or {}
        if effect is None or q.get("gain") is None or r.get("accumulate"):
            continue
        # against the forward frame measured on the same kind of machine (bench --cluster)
        base = r.get("forward_ms", base_ms)
        if base is None:  # none was: no cost to compare
            continue
        delta = r["frame_ms"]["mean"] - base  # negative: cheaper than the forward baseline here
        extra = max(delta, 1e-3)
        cand = {"config": r["config"], "effect": effect, "gain": q["gain"], "extra_ms": extra, "delta_ms": delta,
                "gain_per_ms": q["gain"] / extra}
        if cand["gain"] >= MIN_GAIN and (effect not in best or cand["gain_per_ms"] > best[effect]["gain_per_ms"]):
            best[effect] = cand
    chosen, spent = [], 0.0
    for cand in sorted(best.values(), key=lambda c: -c["gain_per_ms"]):
        if budget_ms is not None and spent + cand["extra_ms"] > budget_ms:
            continue
        chosen.append(cand)
        spent += cand["extra_ms"]
    text = " + ".join(EFFECT_NAME[c["effect"]] for c in chosen) or "the raster baseline (no effect gains enough)"
    return {"chosen": chosen, "candidates": sorted(best.values(), key=lambda c: -c["gain_per_ms"]),
            "extra_ms": spent, "text": text}
