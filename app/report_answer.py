"""The report's first part: the answer. Per scene the measured recommendation and why (its cost
against its quality gain), a cost-vs-quality plot of that scene, and the images that show it:
forward, the recommended effect, the reference and the FLIP maps. Then how the answer and the
frame rates compare with the study's own (its tables and conclusions, ../shared/study/)."""
from __future__ import annotations

from pathlib import Path

from app.recommend import EFFECT_NAME, EFFECT_OF, MIN_GAIN, STUDY, STUDY_EFFECTS, STUDY_FPS, recommend
from app.report_format import markdown_table, plain_log_ticks, save_figure


def _cost(delta_ms: float) -> str:
    """An effect's frame time against the forward baseline's, in words."""
    if delta_ms < 0:  # the pass alone beats forward's frame (a compute GPU's slow GL, or a heavy raster)
        return f"its frame {-delta_ms:.1f} ms shorter than forward's"
    return f"for {delta_ms:.1f} ms a frame more than forward"


def scene_answer(doc: dict, scene: str, budget_ms) -> dict:
    """What the report says about one scene: the pick, each effect's best candidate and why it
    was taken or left, and the study's verdict for the archetype."""
    rows = [r for r in doc["results"] if r["scene"] == scene]
    rec = recommend(rows, budget_ms)
    chosen = {c["effect"] for c in rec["chosen"]}
    reasons = []
    for c in rec["candidates"]:
        verb = "taken" if c["effect"] in chosen else "left out: over the frame-time budget"
        reasons.append(f"{EFFECT_NAME[c['effect']]} ({c['config']}): {_gain(c['gain'])}, {_cost(c['delta_ms'])} "
                       f"— {verb}")
    measured = {r["config"]: r for r in rows}
    for effect in EFFECT_NAME:
        if effect in {c["effect"] for c in rec["candidates"]}:
            continue
        gains = [(measured[cfg]["quality"]["gain"], cfg) for cfg, e in EFFECT_OF.items()
                 if e == effect and (measured.get(cfg) or {}).get("quality")]
        if gains:
            g, cfg = max(gains)
            why = (f"less than the {MIN_GAIN} a viewer would notice" if g >= 0 else
                   "it takes the image away from the reference")
            reasons.append(f"{EFFECT_NAME[effect]} ({cfg}): {_gain(g)} — left out: {why}")
    base = scene.partition(":")[0]
    archetype, study_text = STUDY.get(base, ("(not a study archetype)", None))
    return {"scene": scene, "rec": rec, "reasons": reasons, "archetype": archetype, "study": study_text,
            "study_effects": STUDY_EFFECTS.get(base), "chosen_effects": chosen}


def _gain(gain: float) -> str:
    """A quality gain (forward's mean FLIP minus the effect's) in words."""
    if gain >= 0:
        return f"mean FLIP {gain:.3f} closer to the reference than forward"
    return f"mean FLIP {-gain:.3f} further from the reference than forward"


def agreement(answer: dict) -> str:
    """Where the measured answer and the study's differ, in words."""
    theirs, ours = answer["study_effects"], answer["chosen_effects"]
    if theirs is None:
        return "no study verdict for this scene"
    if theirs == ours:
        return "agrees with the study"
    parts = []
    if ours - theirs:
        parts.append("also " + ", ".join(EFFECT_NAME[e] for e in sorted(ours - theirs)))
    if theirs - ours:
        parts.append("not " + ", ".join(EFFECT_NAME[e] for e in sorted(theirs - ours)))
    return "differs: " + "; ".join(parts)


def flip_map_path(folder: Path, scene: str, config: str, against: str = "reference") -> str | None:
    """images/SCENE_CONFIG_flip.png (the bench writes it at the quality size); made here from the
    two images when a folder predates it. None where the images are not there."""
    rel = f"images/{scene}_{config}_flip.png"
    if (folder / rel).is_file():
        return rel
    ref, test = folder / f"images/{scene}_{against}.png", folder / f"images/{scene}_{config}.png"
    if not (ref.is_file() and test.is_file()):
        return None
    from app.image_io import read_png, write_png
    from app.quality import flip_map

    a, b = read_png(ref), read_png(test)
    if a.shape != b.shape:
        return None
    write_png(folder / rel, flip_map(a, b)[1])
    return rel


def strip(folder: Path, answer: dict) -> list[tuple[str, str]]:
    """(caption, image) pairs: forward, each recommended configuration, the reference, then the
    FLIP maps of forward and of the first recommended configuration against the reference."""
    scene = answer["scene"]
    picks = [c["config"] for c in answer["rec"]["chosen"]]
    out = []
    for cfg in ["forward"] + picks + ["reference"]:
        rel = f"images/{scene}_{cfg}.png"
        if (folder / rel).is_file():
            out.append((cfg, rel))
    for cfg in ["forward"] + picks[:1]:
        rel = flip_map_path(folder, scene, cfg)
        if rel:
            out.append((f"FLIP map: {cfg} vs reference", rel))
    return out


def scene_plot(doc: dict, folder: Path, scene: str, answer: dict) -> str | None:
    """This scene's configurations, frame time against mean FLIP (lower left is better), the
    forward baseline and the recommended ones marked. Returns the file name, or None."""
    rows = [r for r in doc["results"] if r["scene"] == scene and r.get("quality") and not r["accumulate"]]
    if not rows:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    picks = {c["config"] for c in answer["rec"]["chosen"]}
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for r in rows:
        x, y = r["frame_ms"]["mean"], r["quality"]["flip_accumulated"]
        kind = "forward" if r["config"] == "forward" else "picked" if r["config"] in picks else "other"
        ax.scatter([x], [y], s=40 if kind != "other" else 18,
                   c={"forward": "black", "picked": "tab:red", "other": "tab:blue"}[kind],
                   marker={"forward": "s", "picked": "*", "other": "o"}[kind], zorder=3)
        ax.annotate(r["config"], (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_xscale("log")
    plain_log_ticks(ax.xaxis)
    ax.set_xlabel("frame time (ms, log)")
    ax.set_ylabel("mean FLIP vs reference")
    ax.set_title(f"{scene}: cost vs quality (square: forward, star: recommended)", fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    name = save_figure(fig, folder / f"plot_answer_{scene}.png")
    plt.close(fig)
    return name


def study_rows(doc: dict) -> list[list[str]]:
    """Each technique's frame rate here beside the study's (Falcor on its GPU), and each one's
    cost against its own scene's forward frame: the study's ratio beside ours."""
    idx = {(r["scene"], r["config"]): r for r in doc["results"]}
    rows = []
    for cfg, by_scene in STUDY_FPS.items():
        for scene in doc["scenes"]:
            base = scene.partition(":")[0]
            theirs = by_scene.get(base)
            mine = idx.get((scene, cfg))
            if mine is None or base not in STUDY:
                continue
            fwd_theirs, fwd_mine = STUDY_FPS["forward"].get(base), idx.get((scene, "forward"))
            ratio_t = f"{theirs / fwd_theirs:.2f}" if theirs and fwd_theirs else "–"
            ratio_m = f"{mine['fps'] / fwd_mine['fps']:.2f}" if fwd_mine else "–"
            rows.append([scene, cfg, f"{theirs:g}" if theirs else "N/A", f"{mine['fps']:.1f}",
                         ratio_t if cfg != "forward" else "1", ratio_m if cfg != "forward" else "1"])
    return rows


STUDY_HEADER = ["scene", "config", "study fps", "fps here", "study: fps / forward fps", "here: fps / forward fps"]
STUDY_TEXT = (
    "The study's frame rates (Falcor's forward renderer and its passes, 1920×1080, 60 s each, on an NVIDIA "
    "Ampere GPU; N/A where it has none) beside this run's, and each pass's frame rate as a share of its scene's "
    "forward frame rate. Why they differ: the study timed each ray-traced pass alone, after Falcor's G-buffer "
    "pass, on a graphics GPU, while rtlab's forward frame is rasterised by OpenGL here (on a compute GPU such as "
    "the H100 or H200 that is slow: two graphics-capable TPCs) and its ray-traced passes run on the ray-tracing "
    "backend; the scenes are rtlab's procedural stand-ins for the study's ORCA scenes (far fewer triangles); and "
    "the study chose its effects by eye, rtlab by mean FLIP against a converged path-traced reference of the same "
    "view, so an effect the study saw in other views, or valued for looks a reference does not reward, can be "
    "left out here. Ambient occlusion, for one, only darkens the forward renderer's constant ambient term; the "
    "reference's ambient is the light that bounces, which GI traces, so against it AO seldom gains.")


def answer_sections(doc: dict, folder: Path, budget_ms) -> dict | None:
    """The report's opening (None where quality was not measured): each scene's answer with its
    plot and images, the Markdown of it all, and the rows comparing with the study."""
    if not any(r.get("quality") for r in doc["results"]):
        return None

    answers = [scene_answer(doc, s, budget_ms) for s in doc["scenes"]]
    md = ["## The answer", ""] + markdown_table(ANSWER_HEADER, [answer_row(a) for a in answers]) + [""]
    for a in answers:
        a["plot"], a["images"] = scene_plot(doc, folder, a["scene"], a), strip(folder, a)
        md += [f"### {a['scene']}: {a['rec']['text']}", "", scene_line(a), ""]
        md += [f"- {line}" for line in a["reasons"]] + [""]
        if a["plot"]:
            md += [f"![{a['scene']}: cost vs quality]({a['plot']})", ""]
        if a["images"]:
            md += [" ".join(f"![{c}]({p})" for c, p in a["images"]), "", " · ".join(c for c, _ in a["images"]), ""]
    srows = study_rows(doc)
    if srows:
        md += ["## Against the study", "", STUDY_TEXT, ""] + markdown_table(STUDY_HEADER, srows) + [""]
    return {"answers": answers, "markdown": md, "study_rows": srows}


ANSWER_HEADER = ["scene", "recommendation (measured)", "study's recommendation", "agreement"]


def answer_row(a: dict) -> list[str]:
    return [a["scene"], a["rec"]["text"], a["study"] or "–", agreement(a)]


def scene_line(a: dict) -> str:
    return f"Study archetype: {a['archetype']}; the study recommends {a['study'] or '–'} ({agreement(a)})."
