"""screenshots/compare_SCENE.png from a report folder (rtlab study / bench): per scene with quality,
forward, each recommended configuration and the reference side by side, then the FLIP maps of
forward and of the first pick, each captioned with its mean FLIP. Usage:
    python scripts/compare_screenshots.py report/h100-study screenshots"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from PIL import Image, ImageDraw

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.report_answer import scene_answer, strip  # noqa: E402

BAR = 18  # caption bar height, px
TILE = 320  # tile width, px


def compare(folder: Path, doc: dict, scene: str) -> Image.Image | None:
    answer = scene_answer(doc, scene, None)
    flips = {r["config"]: r["quality"]["flip_accumulated"] for r in doc["results"]
             if r["scene"] == scene and r.get("quality")}
    tiles = []
    for caption, rel in strip(folder, answer):
        cfg = caption.removeprefix("FLIP map: ").split(" vs ")[0]
        if cfg in flips:
            caption += f"  (FLIP {flips[cfg]:.3f})"
        tiles.append((caption, Image.open(folder / rel).convert("RGB")))
    if not tiles:
        return None
    w, h = TILE, round(tiles[0][1].height * TILE / tiles[0][1].width)
    out = Image.new("RGB", (w * len(tiles), h + BAR), "black")
    draw = ImageDraw.Draw(out)
    for i, (caption, im) in enumerate(tiles):
        out.paste(im.resize((w, h), Image.LANCZOS), (i * w, BAR))
        draw.text((i * w + 4, 3), caption, fill="white")
    return out


def main(folder: str, dest: str) -> int:
    folder, dest = Path(folder), Path(dest)
    doc = json.loads((folder / "results.json").read_text())
    for scene in doc["scenes"]:
        im = compare(folder, doc, scene)
        if im is not None:
            im.save(dest / f"compare_{scene}.png", optimize=True)
            print(dest / f"compare_{scene}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
