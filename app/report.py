"""`rtlab report DIR`: tables in the study's layout, per-pass breakdown, plots, a gallery and
per-scene recommendations from a bench folder's results.json (report.md + report.html)."""
from __future__ import annotations

import html
import json
from pathlib import Path

from app.bench_configs import DENOISE_MATCH, FLICKER_FRAMES, RAW_FRAMES
from app.image_io import write_text
from app.machine import machine_label
from app.recommend import STUDY, recommend, rule_text
from app.report_answer import ANSWER_HEADER, STUDY_HEADER, STUDY_TEXT, answer_row, answer_sections, scene_line
from app.report_format import markdown_table as _table
from app.report_format import plain_log_ticks as _plain_log_ticks
from app.report_format import save_figure as _save
from core.errors import UserError

TECHNIQUES = [
    ("Reflections", "reflections"), ("Shadows (all lights)", "shadows_all"), ("Shadows (one light)", "shadows_one"),
    ("GI, 1 ray/pixel", "gi_1"), ("GI, 4 rays/pixel", "gi_4"), ("GI + shadows", "gi_shadows"),
    ("AO, 1 ray/pixel", "ao_1"), ("AO, 4 rays/pixel", "ao_4"), ("Hybrid (RT shadows + RT AO)", "hybrid"),
    ("Hybrid (RT shadows + RT GI)", "hybrid_gi"),
]


def load_results(folder: Path) -> dict:
    path = folder / "results.json"
    if not path.is_file():
        raise UserError(f"{folder}: no results.json (run rtlab bench --out {folder} first)")
    try:
        doc = json.loads(path.read_text())
        doc["results"], doc["scenes"]  # noqa: B018 - both must exist
    except (ValueError, KeyError, TypeError) as e:
        raise UserError(f"{path}: not an rtlab results file ({e})") from None
    return doc


def _index(doc: dict) -> dict:
    return {(r["scene"], r["config"]): r for r in doc["results"]}


def technique_tables(doc: dict) -> list[tuple[str, list[str], list[list[str]]]]:
    """One table per technique, scenes as columns, fps (the study's layout)."""
    idx, scenes = _index(doc), list(doc["scenes"])
    tables = []
    for title, cfg in TECHNIQUES:
        if not any((s, cfg) in idx for s in scenes):
            continue
        rows = []
        for label, key in (("Rasterised forward", "forward"), (f"{title}", cfg), (f"{title} + accumulation",
                                                                                     f"{cfg}+acc")):
            if any((s, key) in idx for s in scenes):
                rows.append([label] + [f"{idx[(s, key)]['fps']:.2f}" if (s, key) in idx else "–" for s in scenes])
        rows.append(["cost vs forward"] + [
            f"×{idx[(s, cfg)]['relative_cost']:.1f}" if idx.get((s, cfg), {}).get("relative_cost") else "–"
                                           for s in scenes])
        tables.append((f"{title}: frames per second", ["fps"] + scenes, rows))
    return tables


def machine_keys(doc: dict) -> dict[str, str]:
    """Each kind of machine that measured rows as M1, M2, ... where there was more than one
    (bench --cluster), most rows first; {} otherwise."""
    counts: dict[str, int] = {}
    for r in doc["results"]:
        kind = (r.get("measured_on") or {}).get("kind", "?")
        counts[kind] = counts.get(kind, 0) + 1
    if len(counts) < 2:
        return {}
    return {kind: f"M{i + 1}" for i, kind in enumerate(sorted(counts, key=lambda k: -counts[k]))}


def breakdown_rows(doc: dict) -> list[list[str]]:
    rows, keys = [], machine_keys(doc)
    for r in doc["results"]:
        if r["accumulate"]:
            continue
        parts = ", ".join(f"{k} {v:.1f}" for k, v in sorted(r["passes_ms"].items(), key=lambda kv: -kv[1]))
        timed = r.get("gpu_ms", 0.0) > 0  # GL's timer queries and a GPU backend's timestamps
        rows.append([r["scene"], r["config"], f"{r['frame_ms']['mean']:.1f}", f"{r['frame_ms']['median']:.1f}",
                     f"{r['frame_ms']['p5']:.1f}–{r['frame_ms']['p95']:.1f}", f"{r['mrays_per_s']:.2f}",
                     f"{r['gpu_ms']:.2f}" if timed else "–", f"{r['host_overhead_ms']:.2f}" if timed else "–",
                     f"{r['transfer_ms']:.1f}", parts] + ([keys[(r.get("measured_on") or {}).get("kind", "?")]]
                                                         if keys else []))
    return rows


SPLIT_HEADER = ["scene", "config", "frame ms", "G-buffer", "ray traced", "raster lighting", "denoise", "finish",
                "other", "host beyond"]
SPLIT_TEXT = ("Each frame's mean time by part (ms; with a GPU ray-tracing backend, GPU time): the G-buffer "
              "(raster, packing and copies, or primary rays), the "
              "ray-traced effects (their rays and shading; `rtlab bench --perf` times the rays alone), the raster "
              "lighting (shadow maps, SSAO, forward), the denoiser, the finish (accumulation, tone mapping, display "
              "and the copies that show it), and the host's time beyond them (Python, waits; negative where timed "
              "GL work overlapped the host's).")


def split_rows(doc: dict) -> list[list[str]]:
    """The frame split of each timed configuration (bench_configs.frame_split; made here from
    the passes' times for results that predate it)."""
    from app.bench_configs import frame_split

    rows = []
    for r in doc["results"]:
        if r["accumulate"]:
            continue
        split = r.get("split_ms") or frame_split(r["passes_ms"], r["frame_ms"]["mean"], r.get("pass_kind"))
        rows.append([r["scene"], r["config"], f"{r['frame_ms']['mean']:.1f}"]
                    + [f"{split.get(k, 0.0):.1f}" for k in SPLIT_HEADER[3:]])
    return rows


def quality_rows(doc: dict) -> list[list[str]]:
    rows = []
    for r in doc["results"]:
        q = r.get("quality")
        if not q or r["accumulate"]:
            continue
        rows.append([r["scene"], r["config"], f"{q['flip_single']:.4f}", f"{q['flip_accumulated']:.4f}",
                     f"{q['psnr_single']:.2f}", f"{q['psnr_accumulated']:.2f}", f"{q['gain']:+.4f}"])
    return rows


def _between(n: int) -> list[int]:
    """The raw frame counts the bench measures (bench_configs.RAW_FRAMES) between 1 and n."""
    return [m for m in RAW_FRAMES if 1 < m < n]


def denoise_rows(doc: dict) -> list[list[str]]:
    """Each denoised configuration (bench.measure_denoisers): the denoiser's own time at the
    timing size, and mean FLIP against the pass converged, beside the raw frames'."""
    rows = []
    for r in doc["results"]:
        d = r.get("denoise")
        if not d:
            continue
        denoiser = r["config"].partition("+")[2]
        n = d["frames"]
        match = d.get("match", n)  # the raw frames this denoiser is held against (results before: n)

        def got(key, fmt, d=d):  # absent in results made before it was measured
            return "–" if d.get(key) is None else fmt(d[key])

        # on a GPU backend the denoiser's GPU time (its host-side pass only records the work)
        ms = r["passes_ms"].get(f"{denoiser}_gpu", r["passes_ms"].get(denoiser, float("nan")))
        beats = "–" if d.get(f"flip_raw_{match}") is None else (
            f"{'yes' if d['flip'] <= d[f'flip_raw_{match}'] else 'no'} (vs {match})")
        rows.append([r["scene"], r["config"], f"{ms:.1f}",
                     f"{d['flip_raw_1']:.4f}", *(got(f"flip_raw_{m}", lambda v: f"{v:.4f}") for m in _between(n)),
                     f"{d[f'flip_raw_{n}']:.4f}", f"{d['flip']:.4f}",
                     got("bias", lambda v: f"{100 * v:+.1f} %"),
                     got(f"rel_mse_raw_{n}", lambda v: f"{v:.4f}"), got("rel_mse", lambda v: f"{v:.4f}"),
                     got("flicker_raw_1", lambda v: f"{v:.4f}"), got(f"flicker_raw_{n}", lambda v: f"{v:.4f}"),
                     got("flicker", lambda v: f"{v:.4f}"), beats])
    return rows


def path_rows(doc: dict) -> list[list[str]]:
    """The camera path flown with and without reprojection (bench.measure_path), per scene."""
    def fmt(v):
        return "–" if v is None else f"{v:.4f}"

    rows = []
    for name, info in doc.get("scenes", {}).items():
        p = info.get("path")
        if p:
            a, b, c = p["restart"], p["reproject"], p.get("svgf", {})  # results before SVGF's flight lack it
            rows.append([name, f"{p['config']} ×{p['frames']}", fmt(a["flip_mean"]), fmt(b["flip_mean"]),
                         fmt(c.get("flip_mean")), fmt(a["flicker"]), fmt(b["flicker"]), fmt(c.get("flicker"))])
    return rows


def reference_noise_lines(doc: dict) -> list[str]:
    """Each scene's reference noise (bench.converge_reference), when the results have it."""
    lines = []
    for name, info in doc.get("scenes", {}).items():
        r = info.get("reference")
        if r:
            verdict = "reached" if r["reached"] else "**not reached**"
            lines.append(f"- {name}: {r['frames']} frames; two halves of {r['half_frames']} differ by FLIP "
                         f"{r['half_flip']:.4f}, RMSE {r['half_rmse']:.4f} (target FLIP {r['target_flip']}: {verdict})")
    return ["The references' own noise:", ""] + lines + [""] if lines else []


def recommendation_rows(doc: dict, budget_ms) -> list[list[str]]:
    rows = []
    for scene in doc["scenes"]:
        rec = recommend([r for r in doc["results"] if r["scene"] == scene], budget_ms)
        base = scene.partition(":")[0]
        archetype, study = STUDY.get(base, ("(not a study archetype)", "–"))
        why = "; ".join(f"{c['config']}: gain {c['gain']:.3f} for {c.get('delta_ms', c['extra_ms']):+.0f} ms"
                        for c in rec["chosen"])
        rows.append([scene, rec["text"], why or "–", archetype, study])
    return rows


OUTSIDE = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}  # legends beside the axes,
# never over the data (tight_layout makes room for them)


def make_plots(doc: dict, folder: Path) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    idx, scenes = _index(doc), list(doc["scenes"])
    label = machine_label(doc["machine"], doc.get("tracer"))
    w, h = doc["settings"]["size"]
    plots = []
    configs = ["forward"] + [c for _, c in TECHNIQUES]
    configs = [c for c in configs if any((s, c) in idx for s in scenes)]
    fig, ax = plt.subplots(figsize=(11, 4.5))
    width = 0.8 / max(len(configs), 1)
    for k, cfg in enumerate(configs):
        xs = [i + k * width for i, s in enumerate(scenes) if (s, cfg) in idx]
        ys = [idx[(s, cfg)]["fps"] for s in scenes if (s, cfg) in idx]
        ax.bar(xs, ys, width, label=cfg)
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(scenes))], scenes)
    ax.set_yscale("log")
    _plain_log_ticks(ax.yaxis)
    ax.set_ylabel("frames per second (log)")
    ax.set_title(f"fps per technique, {w}x{h}\n{label}", fontsize=9)
    ax.legend(fontsize=7, ncol=1, **OUTSIDE)
    fig.tight_layout()
    plots.append(("fps per technique per scene", _save(fig, folder / "plot_fps.png")))
    plt.close(fig)

    rows = [r for r in doc["results"] if r.get("quality") and not r["accumulate"]]
    if rows:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for s in scenes:
            pts = [r for r in rows if r["scene"] == s]
            ax.scatter([r["frame_ms"]["mean"] for r in pts], [r["quality"]["flip_accumulated"] for r in pts], label=s)
            for r in pts:
                ax.annotate(r["config"], (r["frame_ms"]["mean"], r["quality"]["flip_accumulated"]), fontsize=6)
        ax.set_xscale("log")
        _plain_log_ticks(ax.xaxis)
        ax.set_xlabel("frame time (ms, log)")
        ax.set_ylabel("mean FLIP vs reference (lower is better)")
        ax.set_title(f"cost vs quality\n{label}", fontsize=9)
        ax.legend(fontsize=7, **OUTSIDE)
        fig.tight_layout()
        plots.append(("cost vs quality", _save(fig, folder / "plot_cost_quality.png")))
        plt.close(fig)

        fig, ax = plt.subplots(figsize=(8, 4.5))
        pixels = w * h
        for fam in ("gi", "ao"):
            for s in scenes:
                pts = [r for r in rows if r["scene"] == s and r["config"] in (f"{fam}_1", f"{fam}_4")]
                if len(pts) == 2:
                    ax.plot([r["rays_per_frame"] / pixels for r in pts], [r["quality"]["flip_single"] for r in pts],
                            marker="o", label=f"{fam} {s}")
        ax.set_xlabel("rays per pixel per frame")
        ax.set_ylabel("mean FLIP of one frame (noise)")
        ax.set_title(f"rays per pixel vs error\n{label}", fontsize=9)
        if ax.get_legend_handles_labels()[0]:  # none where gi_4 / ao_4 were not measured
            ax.legend(fontsize=7, **OUTSIDE)
        fig.tight_layout()
        plots.append(("rays per pixel vs error", _save(fig, folder / "plot_rays_error.png")))
        plt.close(fig)
    return plots


def gallery(doc: dict, folder: Path) -> list[tuple[str, list[tuple[str, str]]]]:
    out = []
    for scene in doc["scenes"]:
        items = []
        for cfg in ["reference", "forward"] + [c for _, c in TECHNIQUES]:
            name = f"images/{scene}_{cfg}.png"
            if (folder / name).is_file():
                items.append((cfg, name))
        if items:
            out.append((scene, items))
    return out


def cluster_section(doc: dict):
    """A run on a Ray cluster (bench --cluster): the cluster, and each kind of machine with the
    rows it measured (results.json has each row's host and node in measured_on); None otherwise."""
    c = doc["machine"].get("cluster")
    if not c:
        return None
    text = (f"Measured on a Ray cluster ({c['address']}): {c['nodes']} node(s), {c['gpus']} GPU(s), {c['cpus']} "
            f"CPUs; tasks took {c['tasks']}. Each row's cost against the forward frame compares it with the forward "
            "frame measured on the same kind of machine.")
    by_kind: dict[str, list] = {}
    for r in doc["results"]:
        on = r.get("measured_on") or {}
        by_kind.setdefault(on.get("kind", "?"), []).append(r)
    keys = machine_keys(doc)
    rows = [[(f"{keys[kind]}: " if keys else "") + kind, str(len(rs)),
             ", ".join(sorted({(r.get("measured_on") or {}).get("host", "?") for r in rs}))]
            for kind, rs in sorted(by_kind.items(), key=lambda kv: -len(kv[1]))]
    return text, ["machine (kind)", "rows measured", "hosts"], rows


def write_report(folder: Path, doc: dict, html: bool = True, budget_ms=None) -> None:
    budget_ms = budget_ms if budget_ms is not None else doc["settings"].get("budget_ms")
    label = machine_label(doc["machine"], doc.get("tracer"))
    s = doc["settings"]
    when = f"{s['frames']} frames" if s.get("frames") else f"{s.get('seconds')} s"
    commit = doc.get("commit") or "not recorded"
    md = ["# rtlab benchmark report", "",
          f"Machine: **{label}**. Commit: {commit}. Created {doc.get('created', '?')}.", "",
          f"Timing: {s['size'][0]}×{s['size'][1]}, {s['warmup']} warm-up frames, then {when} per configuration; "
          "each technique's own pass (as the study measured). "
          + (f"Quality: {s['quality_size'][0]}×{s['quality_size'][1]}, the forward renderer with that effect ray "
             f"traced, one frame and {s['quality_frames']} accumulated frames, against the reference path tracer "
             f"converged over {s['reference_frames']} frames; mean FLIP (LDR) and PSNR." if s.get("quality") else
             "Quality was not measured (--no-quality)."), ""]
    cluster = cluster_section(doc)
    if cluster:
        md += [cluster[0], ""] + _table(cluster[1], cluster[2]) + [""]
    if doc.get("merged_from"):
        md += [f"Results of {len(doc['merged_from'])} bench runs on this machine, concatenated: "
               + "; ".join(f"`rtlab {m}`" for m in doc["merged_from"]) + ".", ""]
    if doc.get("note"):  # what someone who merged or edited the results says about them
        md += [str(doc["note"]), ""]
    intro = [line for line in md[1:] if line and not line.startswith("|")]  # machine, protocol, notes
    answer = answer_sections(doc, folder, budget_ms)  # the answer first: per scene, then against the study
    if answer:
        md += answer["markdown"]
    sections = []
    for title, header, rows in technique_tables(doc):
        sections.append((title, header, rows))
        md += [f"## {title}", ""] + _table(header, rows) + [""]
    bh = ["scene", "config", "mean ms", "median ms", "p5–p95 ms", "Mrays/s", "GPU ms", "host beyond GPU ms",
          "transfers ms", "per pass (ms)"] + (["machine"] if machine_keys(doc) else [])
    md += ["## Per-pass time breakdown", ""] + _table(bh, breakdown_rows(doc)) + [""]
    md += ["## Frame split", "", SPLIT_TEXT, ""] + _table(SPLIT_HEADER, split_rows(doc)) + [""]
    qrows = quality_rows(doc)
    qh = ["scene", "config", "FLIP 1 frame", "FLIP accumulated", "PSNR 1 frame", "PSNR accumulated",
          "gain vs forward"]
    if qrows:
        md += ["## Quality against the reference", ""] + _table(qh, qrows) + [""] + reference_noise_lines(doc)
        rh = ["scene", "measured recommendation", "why", "study archetype", "study's recommendation"]
        rrows = recommendation_rows(doc, budget_ms)
        md += ["## Recommendations", "", f"Rule: {rule_text(budget_ms)}", ""] + _table(rh, rrows) + [""]
    drows = denoise_rows(doc)
    if drows:
        first = next(r["denoise"] for r in doc["results"] if r.get("denoise"))
        n = first["frames"]
        dh = ["scene", "config", "denoiser ms", "FLIP 1 raw frame",
              *(f"FLIP {m} raw frames" for m in _between(n) + [n]), f"FLIP denoised (frame {n})", "bias denoised",
              f"relMSE {n} raw", "relMSE denoised",
              "flicker raw", f"flicker {n} raw", "flicker denoised", "denoised ≤ raw"]
        size = "×".join(str(v) for v in s["quality_size"])
        md += ["## Denoisers", "", "Each pass's image against the same pass converged over "
               f"{first['converged_frames']} accumulated frames (mean FLIP, {size}): one raw frame, "
               f"{' and '.join(str(m) for m in _between(n) + [n])} "
               f"accumulated raw frames, and the {n}th frame of a still camera denoised without accumulation (SVGF's "
               "history built over the frames before; OIDN filters each frame alone). The last column holds each "
               f"denoiser against the raw frames its image stands for: SVGF's {n}th frame (its history holds {n} "
               f"frames' samples) against as many accumulated, OIDN's single frame against "
               f"{DENOISE_MATCH['oidn']}. The bias is the denoised image's mean brightness against the converged "
               "one's (linear light), apart from its noise; the "
               "relative MSE (linear light, each channel's squared error over the converged value's square + 0.01) "
               "holds both. The flicker is the mean change of a pixel's displayed luminance (0-1) from frame to "
               f"frame over the last {FLICKER_FRAMES} frames of the still camera: raw frames alone, {n} raw frames "
               "accumulated, denoised. The "
               f"denoiser's time is its own pass at {s['size'][0]}×{s['size'][1]} (its GPU time on a GPU "
               "backend).", ""] + _table(dh, drows) + [""]
    prows = path_rows(doc)
    if prows:
        first = next(i["path"] for i in doc["scenes"].values() if i.get("path"))
        ph = ["scene", "path", "FLIP restart", "FLIP reproject", "FLIP svgf", "flicker restart", "flicker reproject",
              "flicker svgf"]
        md += ["## Camera path", "", f"A dolly through the scene ({first['frames']} frames), accumulating as the "
               "study measured (the mean restarts on motion), with `reproject=true`, and denoised by SVGF (its "
               "history reprojected: lag and ghosts count here): mean FLIP of frames "
               f"{', '.join(str(k + 1) for k in first['checked_frames'])} against their camera's converged image "
               f"({first['converged_frames']} frames), and the flicker, the mean change of a point's displayed "
               "luminance from one frame to the next.", ""] + _table(ph, prows) + [""]
    plots = make_plots(doc, folder)
    md += ["## Plots", ""] + [f"![{t}]({p})" for t, p in plots] + [""]
    gal = gallery(doc, folder)
    if gal:
        md += ["## Gallery (same view; forward vs each technique swapped in)", ""]
        for scene, items in gal:
            md += [f"### {scene}", "", " ".join(f"![{c}]({p})" for c, p in items), "",
                   " · ".join(c for c, _ in items), ""]
    write_text(folder / "report.md", "\n".join(md))
    if html:
        tables = {"breakdown": (bh, breakdown_rows(doc)), "quality": (qh, qrows),
                  "denoise": (dh, drows) if drows else None, "path": (ph, prows) if prows else None}
        write_html(folder, doc, {"intro": intro, "answer": answer, "sections": sections, "tables": tables,
                                 "budget_ms": budget_ms, "plots": plots, "gallery": gal})


def _img(rel: str, alt: str = "") -> str:
    """An image beside the report, linked (the report stays small; open it from its folder)."""
    return f'<img src="{html.escape(rel)}" alt="{html.escape(alt or rel)}" loading="lazy">'


def _html_table(header, rows) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def write_html(folder, doc, page: dict) -> None:
    """report.html from what write_report built for report.md (page: intro lines, the answer,
    the fps sections, the other tables as (header, rows), the budget, plots and gallery)."""
    intro, answer, sections, tables = page["intro"], page["answer"], page["sections"], page["tables"]
    budget_ms, plots, gal = page["budget_ms"], page["plots"], page["gallery"]
    (bh, brows), (qh, qrows) = tables["breakdown"], tables["quality"]
    parts = ["<!doctype html><html lang='en'><meta charset='utf-8'><title>rtlab report</title>",
             "<style>body{font-family:sans-serif;margin:2em;max-width:1400px}table{border-collapse:collapse;"
             "margin:1em 0;display:block;overflow-x:auto}td,th{border:1px solid #ccc;padding:3px 8px;font-size:13px}"
             "th{background:#eee}img{max-width:100%;margin:2px}.gal img{width:220px}.strip img{width:300px}"
             "figure{display:inline-block;margin:4px}figcaption{font-size:12px}</style>",
             "<h1>rtlab benchmark report</h1>"]
    parts += [f"<p>{html.escape(line.replace('**', '').replace('`', ''))}</p>" for line in intro]
    cluster = cluster_section(doc)
    if cluster:
        parts.append(_html_table(cluster[1], cluster[2]))
    if answer:
        parts += ["<h2>The answer</h2>", _html_table(ANSWER_HEADER, [answer_row(a) for a in answer["answers"]])]
        for a in answer["answers"]:
            parts += [f"<h3>{html.escape(a['scene'])}: {html.escape(a['rec']['text'])}</h3>",
                      f"<p>{html.escape(scene_line(a))}</p>",
                      "<ul>" + "".join(f"<li>{html.escape(r)}</li>" for r in a["reasons"]) + "</ul>"]
            if a["plot"]:
                parts.append(_img(a["plot"], f"{a['scene']}: cost vs quality"))
            parts.append("<div class='strip'>" + "".join(
                f"<figure>{_img(p, c)}<figcaption>{html.escape(c)}</figcaption></figure>" for c, p in a["images"])
                + "</div>")
        if answer["study_rows"]:
            parts += ["<h2>Against the study</h2>", f"<p>{html.escape(STUDY_TEXT)}</p>",
                      _html_table(STUDY_HEADER, answer["study_rows"])]
    for title, header_row, rows in sections:
        parts += [f"<h2>{html.escape(title)}</h2>", _html_table(header_row, rows)]
    parts += ["<h2>Per-pass time breakdown</h2>", _html_table(bh, brows)]
    parts += ["<h2>Frame split</h2>", f"<p>{html.escape(SPLIT_TEXT)}</p>", _html_table(SPLIT_HEADER, split_rows(doc))]
    if qrows:
        parts += ["<h2>Quality against the reference</h2>", _html_table(qh, qrows),
                  "<h2>Recommendations</h2>", f"<p>Rule: {html.escape(rule_text(budget_ms))}</p>",
                  _html_table(["scene", "measured recommendation", "why", "study archetype", "study's recommendation"],
                              recommendation_rows(doc, budget_ms))]
    if tables["denoise"]:
        parts += ["<h2>Denoisers</h2>", _html_table(*tables["denoise"])]
    if tables["path"]:
        parts += ["<h2>Camera path</h2>", _html_table(*tables["path"])]
    parts += ["<h2>Plots</h2>"] + [_img(p, t) for t, p in plots]
    if gal:
        parts.append("<h2>Gallery</h2>")
        for scene, items in gal:
            parts.append(f"<h3>{html.escape(scene)}</h3><div class='gal'>")
            parts += [f"<figure>{_img(p, c)}<figcaption>{html.escape(c)}</figcaption></figure>" for c, p in items]
            parts.append("</div>")
    write_text(folder / "report.html", "\n".join(parts) + "\n</html>\n")


def run_report(args) -> int:
    folder = Path(args.dir)
    doc = load_results(folder)
    try:  # the report reads nothing but results.json: a value of the wrong kind there is the file's
        write_report(folder, doc, html=True, budget_ms=args.budget_ms)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, ZeroDivisionError) as e:
        raise UserError(f"{folder / 'results.json'}: not an rtlab results file ({type(e).__name__}: "
                        f"{str(e)[:120]})") from None
    print(f"report: {folder}/report.md, {folder}/report.html")
    return 0
