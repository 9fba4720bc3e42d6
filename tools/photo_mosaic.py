#!/usr/bin/python3
"""Wide frames from the DeepFruits photos, to measure a detector on fruit small in a large frame.

Each mosaic is a GRID x GRID grid of cells CELL px square; every photo goes into one cell (scaled so its longer
side is CELL, centred on mid grey), in an order shuffled with --seed, so a 3x3 grid of 400 px cells is a
1200 px frame whose fruit are as many pixels wide as in the photos at 400 px, a third of the frame's scale. Writes
OUT/images/mosaicNN.png and OUT/boxes.csv (the photos' boxes moved into their cells, the format of the photos'
boxes.csv) for `harvest-detect --evaluate OUT/boxes.csv` (docs/perception.md). Needs python3-pil.

    tools/photo_mosaic.py --data ../shared/data/deepfruits-orange --grid 3 --cell 400 --out /tmp/mosaic3
"""
import argparse
import csv
import os
import random

from PIL import Image


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="folder with boxes.csv and images/")
    ap.add_argument("--out", required=True)
    ap.add_argument("--grid", type=int, default=3)
    ap.add_argument("--cell", type=int, default=400, help="[px] cell side")
    ap.add_argument("--seed", type=int, default=19)
    a = ap.parse_args()
    boxes = {}
    with open(os.path.join(a.data, "boxes.csv")) as f:
        for r in csv.DictReader(f):
            boxes.setdefault(r["image"], []).append([int(r[k]) for k in ("x1", "y1", "x2", "y2")])
    names = sorted(boxes)
    random.Random(a.seed).shuffle(names)
    per = a.grid * a.grid
    os.makedirs(os.path.join(a.out, "images"), exist_ok=True)
    side = a.grid * a.cell
    rows = []
    for m in range(0, len(names), per):
        canvas = Image.new("RGB", (side, side), (128, 128, 128))
        name = f"mosaic{m // per:02d}.png"
        for i, photo in enumerate(names[m : m + per]):
            img = Image.open(os.path.join(a.data, "images", photo)).convert("RGB")
            s = a.cell / max(img.size)
            w, h = max(1, round(img.width * s)), max(1, round(img.height * s))
            x0 = (i % a.grid) * a.cell + (a.cell - w) // 2
            y0 = (i // a.grid) * a.cell + (a.cell - h) // 2
            canvas.paste(img.resize((w, h), Image.BILINEAR), (x0, y0))
            for x1, y1, x2, y2 in boxes[photo]:
                rows.append((name, side, side, round(x0 + x1 * s), round(y0 + y1 * s), round(x0 + x2 * s),
                             round(y0 + y2 * s)))
        canvas.save(os.path.join(a.out, "images", name))
    with open(os.path.join(a.out, "boxes.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(("image", "img_w", "img_h", "x1", "y1", "x2", "y2"))
        w.writerows(rows)
    print(f"{(len(names) + per - 1) // per} mosaics of {a.grid}x{a.grid} ({side} px), {len(rows)} boxes -> {a.out}")


if __name__ == "__main__":
    main()
