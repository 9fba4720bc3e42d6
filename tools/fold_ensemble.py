#!/usr/bin/python3
"""Cross-validated figures of fold models trained with other seeds, alone and as ensembles (docs/perception.md,
"Seed ensembles and distillation").

Each DIR holds the fold models of one `tools/train_detector.py --folds 3 --folds-only --train-seed S` run
(fruit_net.fold<k>.onnx, same folds: the default --seed). Every photo is scored by its fold's models only; an
ensemble averages the models' heatmap and mask probabilities and their log diameters, then decodes as the C++
does. Thresholds are nested as in train_detector.py (fold k's from the other folds' photos); matching is the
script's (centre inside the box; harvest-detect --evaluate also matches at IoU >= 0.3, so its counts differ
slightly). Prints each model, the ensemble of all, and the ensembles leaving one out:

  /usr/bin/python3 tools/fold_ensemble.py /tmp/cv19 /tmp/cv119 /tmp/cv219 /tmp/cv319 [--score-visible]
"""
import argparse
import math
import os
import random

import numpy as np
import torch

import train_detector as td
from fold_thresholds import GREEN


def visible(out, u, v, d):
    """Mean mask probability over the cells whose centre lies in the fruit's disc around its sub-cell centre
    (LearnedDetector centres the disc on the peak cell, less than a cell away: close, not the same)."""
    m = torch.sigmoid(out[2]).numpy()
    ys, xs = np.mgrid[0 : m.shape[0], 0 : m.shape[1]]
    inside = ((xs + 0.5) * td.STRIDE - u) ** 2 + ((ys + 0.5) * td.STRIDE - v) ** 2 <= (d / 2) ** 2
    return float(m[inside].mean()) if inside.any() else 0.0


def combine(outs, logits=False):
    """Maps of several models: mean probabilities (back to logits), or mean logits (what one merged network,
    tools/merge_models.py, computes), and mean log diameter."""
    if len(outs) == 1:
        return outs[0]
    o = torch.stack(outs)
    if logits:
        return o.mean(0)
    logit = lambda p: torch.logit(p.clamp(1e-6, 1 - 1e-6))
    return torch.stack([logit(torch.sigmoid(o[:, 0]).mean(0)), o[:, 1].mean(0), logit(torch.sigmoid(o[:, 2]).mean(0))])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--data", default="../shared/data/deepfruits-orange")
    ap.add_argument("--folds", type=int, default=3)
    ap.add_argument("--seed", type=int, default=19, help="the folds' seed (train_detector.py --seed)")
    ap.add_argument("--score-visible", action="store_true", help="confidence sqrt(peak x visible fraction)")
    ap.add_argument("--logit-mean", action="store_true", help="average the logits, not the probabilities")
    a = ap.parse_args()
    torch.set_num_threads(1)
    items = td.load(a.data, 320)
    order = list(range(len(items)))
    random.Random(a.seed).shuffle(order)
    fold_of = {i: k for k in range(a.folds) for i in order[k :: a.folds]}
    maps = {}
    with torch.no_grad():
        for d in a.dirs:
            nets = [td.load_teacher(os.path.join(d, f"fruit_net.fold{k}.onnx")) for k in range(a.folds)]
            maps[d] = [nets[fold_of[i]](td.normalise(td.pad4(img))[None])[0] for i, (_, img, _) in enumerate(items)]

    def evaluate(dirs):
        counts = {t: {} for t in td.THRESHOLDS}  # threshold -> photo -> (tp, detections, fruit)
        for i, item in enumerate(items):
            out = combine([maps[d][i] for d in dirs], a.logit_mean)
            dets = td.decode(out, min(td.THRESHOLDS))
            if a.score_visible:
                dets = [(u, v, dd, math.sqrt(s * visible(out, u, v, dd))) for u, v, dd, s in dets]
            for t in td.THRESHOLDS:
                counts[t][i] = td.score(None, [item], t, [dets])[:3]
        total = lambda t, keep: [sum(c[j] for i, c in counts[t].items() if keep(i)) for j in range(3)]
        chosen = [td.best_threshold({t: total(t, lambda i: fold_of[i] != k) for t in td.THRESHOLDS})
                  for k in range(a.folds)]
        best = [max(td.f1(*total(t, lambda i: fold_of[i] == k)) for t in td.THRESHOLDS) for k in range(a.folds)]
        line = f"nested {chosen}, best F1 per fold {' '.join(f'{b:.3f}' for b in best)}"
        for name, keep in (("all", lambda i: True), ("ripe", lambda i: items[i][0] not in GREEN),
                           ("green", lambda i: items[i][0] in GREEN)):
            c = [sum(counts[chosen[fold_of[i]]][i][j] for i in range(len(items)) if keep(i)) for j in range(3)]
            line += f" | {name} P {c[0] / max(c[1], 1):.3f} R {c[0] / max(c[2], 1):.3f} F1 {td.f1(*c):.3f}"
        return line

    name = lambda ds: "+".join(os.path.basename(d.rstrip("/")) for d in ds)
    for d in a.dirs:
        print(f"{name([d])}: {evaluate([d])}", flush=True)
    if len(a.dirs) > 1:
        print(f"ensemble {name(a.dirs)}: {evaluate(a.dirs)}", flush=True)
    if len(a.dirs) > 2:
        for j in range(len(a.dirs)):
            rest = [d for k, d in enumerate(a.dirs) if k != j]
            print(f"ensemble {name(rest)}: {evaluate(rest)}", flush=True)


if __name__ == "__main__":
    main()
