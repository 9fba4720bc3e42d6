#!/usr/bin/python3
"""Nested threshold choice from harvest-detect's own counts (docs/perception.md, "Learned mode").

For a folds.csv of tools/train_detector.py --folds (image,model[,threshold]) it runs
`build/bin/harvest-detect --evaluate --fold-models` once per grid threshold (0.15 .. 0.70), with any
`--set KEY=VALUE` given, picks for fold k the threshold of best F1 on the other folds' photos (fold k's boxes
never choose its threshold), and prints each fold's F1 per threshold, the chosen thresholds, the threshold for
a model trained on all photos (best over all folds) and the figures at the nested thresholds: all photos,
ripe and green apart (the five green-fruit images of docs/perception.md). Run from the repository root:

  /usr/bin/python3 tools/fold_thresholds.py /tmp/cv/folds.csv --set detector.score_visible=true
"""
import argparse
import csv
import json
import os
import subprocess

GREEN = {"n12710693_16214.png", "n12710693_5020.png", "n12710693_4433.png", "n12710693_1211.png",
         "n12710693_19700.png"}
GRID = [round(0.15 + 0.05 * i, 2) for i in range(12)]  # train_detector.py THRESHOLDS


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folds", help="folds.csv of train_detector.py --folds")
    ap.add_argument("--boxes", default="../shared/data/deepfruits-orange/boxes.csv")
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE for harvest-detect (repeatable)")
    a = ap.parse_args()
    rows = list(csv.DictReader(open(a.folds)))
    fold_of = {r["image"]: r["model"] for r in rows}
    models = sorted(set(fold_of.values()))
    counts = {}  # threshold -> image -> (true positives, detections, boxes)
    for t in GRID:
        tmp = os.path.join(os.path.dirname(os.path.abspath(a.folds)), f"folds_at_{t}.csv")
        with open(tmp, "w") as f:
            f.write("image,model,threshold\n")
            f.writelines(f"{r['image']},{r['model']},{t}\n" for r in rows)
        sets = [x for s in ["detector.mode=learned", *a.set] for x in ("--set", s)]
        out = subprocess.run(["build/bin/harvest-detect", *sets, "--evaluate", a.boxes, "--fold-models", tmp],
                             capture_output=True, text=True, check=True).stdout
        counts[t] = {}
        for line in out.splitlines():
            j = json.loads(line)
            if "image" in j:
                counts[t][os.path.basename(j["image"])] = (j["true_positives"], j["fruits"], j["boxes"])

    def total(t, keep):
        return [sum(c[k] for i, c in counts[t].items() if keep(i)) for k in range(3)]

    f1 = lambda c: 2 * c[0] / max(c[1] + c[2], 1)
    for m in models:
        print(m, " ".join(f"{t}:{f1(total(t, lambda i: fold_of[i] == m)):.3f}" for t in GRID))
    chosen = {m: max(GRID, key=lambda t: (f1(total(t, lambda i: fold_of[i] != m)), -t)) for m in models}
    final = max(GRID, key=lambda t: (f1(total(t, lambda i: True)), -t))
    print("nested thresholds", ", ".join(str(chosen[m]) for m in models), "; for a model on all photos", final)
    for what, keep in (("all", lambda i: True), ("ripe", lambda i: i not in GREEN), ("green", lambda i: i in GREEN)):
        c = [sum(counts[chosen[fold_of[i]]][i][k] for i in fold_of if keep(i)) for k in range(3)]
        print(f"{what}: P {c[0] / max(c[1], 1):.3f} R {c[0] / max(c[2], 1):.3f} F1 {f1(c):.3f} "
              f"({c[0]} of {c[2]} fruit, {c[1]} detections)")


if __name__ == "__main__":
    main()
