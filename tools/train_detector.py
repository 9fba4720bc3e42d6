#!/usr/bin/python3
"""Trains the learned fruit detector (docs/perception.md, "Learned mode").

A small fully convolutional net, trained from scratch (no pretrained weights
exist here), maps an RGB image to three maps at 1/4 resolution: fruit-centre
heatmap (logit), log fruit diameter, fruit mask (logit). lib/vision/
learned_detector.cpp decodes them the same way as decode() below.

Data: the DeepFruits orange photos (CC BY 4.0 via deepNIR) given by --data;
never copied into the repository. Images are scaled to --width pixels wide
(the detector does the same at run time), augmented heavily (scale, crop,
flip, colour jitter): 45 photos are little data, so rendered frames with exact
boxes (harvest-sim-frames, --sim) fill a share of every batch; they are never
scored as photos.

  nice -n 19 /usr/bin/python3 tools/train_detector.py --data ../shared/data/deepfruits-orange \
      --sim /tmp/simtrain --folds 3 --out config/vision/models/fruit_net.onnx

With --folds k it first trains k models, each scored only on the photos it
did not see (folds fixed by a seeded shuffle), prints the cross-validated
figures and writes the fold models next to --out (fruit_net.fold<i>.onnx,
and folds.csv, for harvest-detect --evaluate --fold-models); then trains the final model on
all photos. Hyper-parameters were chosen before any fold was scored and are
not tuned on them. The decode threshold is chosen from a grid by F1: for
fold k on the other folds' held-out photos only (nested: fold k's boxes never
choose the threshold it is scored at; folds.csv carries it per image), for
the final model on all folds' held-out photos (set it as detector.threshold).

Tried and not kept (docs/perception.md, off by default): --jitter strong, --mosaic SHARE, distillation from
other seeds' models (--teachers DIR, --teacher-seeds S,...); --train-seed moves the training seeds and keeps
the folds.
"""
import argparse
import csv
import math
import os
import random
import sys
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from PIL import Image, ImageFilter

STRIDE = 4
DIAM_SCALE = 32.0  # diameter channel is log(d / DIAM_SCALE), d in input pixels


class FruitNet(nn.Module):
    """Two stride-2 convolutions to 1/4 resolution, then dilated convolutions
    (receptive field ~ 140 px, a whole fruit at --width 320) and a 1x1 head. A dilation-16 layer more
    (~270 px) and 3500 steps scored better on rendered frames and worse on the photos (docs/perception.md)."""

    def __init__(self, c=32):
        super().__init__()

        def block(i, o, s=1, d=1):
            return [nn.Conv2d(i, o, 3, s, d, dilation=d, bias=False), nn.BatchNorm2d(o), nn.ReLU(inplace=True)]

        layers = block(3, 16, 2) + block(16, 24, 2) + block(24, c) + block(c, c, d=2) + block(c, c, d=4)
        layers += block(c, c, d=8) + block(c, c, d=1)
        self.body = nn.Sequential(*layers)
        self.head = nn.Conv2d(c, 3, 1)
        self.head.bias.data[0] = -4.0  # centres are rare: start the heatmap near 0

    def forward(self, x):
        return self.head(self.body(x))


def load_teacher(path):
    """An exported FruitNet (Conv and Relu nodes) as a function of a batch, for distillation."""
    import onnx
    from fruit_net_parity import run_onnx_in_torch

    model = onnx.load(path)
    return lambda x: run_onnx_in_torch(model, x)


def normalise(rgb_u8):
    """uint8 HxWx3 RGB -> float tensor 3xHxW in [-1, 1] (the C++ side: scale 1/127.5, mean 127.5)."""
    return torch.from_numpy(rgb_u8.astype(np.float32) / 127.5 - 1.0).permute(2, 0, 1)


SCORED_VISIBLE = 0.5  # a rendered fruit less visible is neither found nor missed (box_evaluation.hpp)


def load(data, width):
    """Images of a folder with boxes.csv (image,img_w,img_h,x1,y1,x2,y2[,visible]) scaled to `width`:
    [(name, HxWx3 uint8 RGB, N x 5 boxes x1 y1 x2 y2 visible)]. Photos have no visible column: 1."""
    rows = {}
    with open(os.path.join(data, "boxes.csv")) as f:
        for r in csv.DictReader(f):
            rows.setdefault(r["image"], []).append(
                [float(r[k]) for k in ("x1", "y1", "x2", "y2")] + [float(r.get("visible") or 1.0)])
    items = []
    for name in sorted(rows):
        im = Image.open(os.path.join(data, "images", name)).convert("RGB")
        s = width / im.width
        h = int(round(im.height * s))
        im = im.resize((width, h), Image.BILINEAR)
        items.append((name, np.asarray(im), np.array(rows[name]) * np.array([s, s, s, s, 1.0])))
    return items


def targets(h, w, boxes):
    """Heatmap (Gaussian per centre), log-diameter and its weight, mask, and where the heatmap is not
    penalised (a rendered fruit less than SCORED_VISIBLE visible: neither fruit nor background), all at
    1/4 resolution."""
    H, W = h // STRIDE, w // STRIDE
    heat = np.zeros((H, W), np.float32)
    diam = np.zeros((H, W), np.float32)
    wdiam = np.zeros((H, W), np.float32)
    mask = np.zeros((H, W), np.float32)
    ignore = np.zeros((H, W), np.float32)
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float32)
    xs, ys = (xs + 0.5) * STRIDE, (ys + 0.5) * STRIDE  # cell centres in input pixels
    for x1, y1, x2, y2, visible in boxes:
        cx, cy, bw, bh = (x1 + x2) / 2, (y1 + y2) / 2, x2 - x1, y2 - y1
        if bw < 2 or bh < 2:
            continue
        d = (bw + bh) / 2
        if visible < SCORED_VISIBLE:
            ignore[((xs - cx) / (bw / 2)) ** 2 + ((ys - cy) / (bh / 2)) ** 2 <= 1] = 1
            continue
        sigma = max(STRIDE * 0.75, d / 8)
        g = np.exp(-((xs - cx) ** 2 + (ys - cy) ** 2) / (2 * sigma**2))
        # The cell holding the centre is the fruit's peak (1): a Gaussian reaches 1 only where a cell centre
        # falls on the fruit's centre, and with sigma 3 px a cell 1 px off is already under the 0.95 the
        # focal loss counts as positive, so most small fruit had no positive cell at all.
        ix, iy = int(cx // STRIDE), int(cy // STRIDE)
        if 0 <= ix < W and 0 <= iy < H:
            g[iy, ix] = 1.0
        heat = np.maximum(heat, g)
        near = g > 0.3
        diam[near] = math.log(d / DIAM_SCALE)
        wdiam[near] = np.maximum(wdiam[near], g[near])
        inside = ((xs - cx) / (bw / 2)) ** 2 + ((ys - cy) / (bh / 2)) ** 2 <= 1
        mask[inside] = 1
    ignore[heat > 0.05] = 0  # a visible fruit's own peak always counts
    return heat, diam, wdiam, mask, ignore


def jitter(img, rng, strong=False):
    img = img.astype(np.float32)
    if strong and rng.random() < 0.3:  # defocus / motion: a Gaussian blur of sigma up to 1.2 px
        img = np.asarray(Image.fromarray(img.astype(np.uint8)).filter(
            ImageFilter.GaussianBlur(rng.uniform(0.3, 1.2)))).astype(np.float32)
    gray = img.mean(axis=2, keepdims=True)
    img = gray + (img - gray) * (rng.uniform(0.5, 1.5) if strong else rng.uniform(0.6, 1.4))  # saturation
    img = (img - img.mean()) * rng.uniform(0.7, 1.3) + img.mean()  # contrast
    bright = rng.uniform(0.6, 1.4)
    img = img * bright * rng.uniform(*((0.85, 1.15) if strong else (0.9, 1.1)), size=3)  # brightness, white balance
    if strong:  # gamma: shadows and highlights apart
        img = 255 * (np.clip(img, 0, 255) / 255) ** rng.uniform(0.7, 1.4)
    img += rng.normal(0, rng.uniform(0, 6), img.shape)  # sensor noise
    return np.clip(img, 0, 255).astype(np.uint8)


def sample(item, crop, rng, strong=False, scale=(0.6, 1.6)):
    _, img, boxes = item
    s = rng.uniform(*scale)
    h, w = img.shape[:2]
    nw, nh = max(crop, int(w * s)), max(crop, int(h * s))
    s_x, s_y = nw / w, nh / h
    im = np.asarray(Image.fromarray(img).resize((nw, nh), Image.BILINEAR))
    b = boxes * np.array([s_x, s_y, s_x, s_y, 1.0])
    x0, y0 = rng.integers(0, nw - crop + 1), rng.integers(0, nh - crop + 1)
    im = im[y0 : y0 + crop, x0 : x0 + crop]
    b = b - np.array([x0, y0, x0, y0, 0.0])
    if rng.random() < 0.5:
        im = im[:, ::-1]
        b = np.stack([crop - b[:, 2], b[:, 1], crop - b[:, 0], b[:, 3], b[:, 4]], axis=1)
    # keep boxes whose centre lies in the crop (a cut fruit keeps its full-size box: the diameter is the fruit's)
    c = (b[:, :2] + b[:, 2:4]) / 2
    b = b[(c[:, 0] >= 0) & (c[:, 0] < crop) & (c[:, 1] >= 0) & (c[:, 1] < crop)]
    return jitter(np.ascontiguousarray(im), rng, strong), b


def mosaic(items, crop, rng, strong=False):
    """Four photos' crops of half the side, each at scale 0.5..1.2, tiled 2x2: more fruit, smaller and in other
    surroundings, per sample (each box kept in the quadrant holding its centre)."""
    half = crop // 2
    im = np.zeros((crop, crop, 3), np.uint8)
    out = []
    for qy in (0, half):
        for qx in (0, half):
            q, b = sample(items[rng.integers(len(items))], half, rng, strong, scale=(0.5, 1.2))
            im[qy : qy + half, qx : qx + half] = q
            out.append(b + np.array([qx, qy, qx, qy, 0.0]))
    return im, np.concatenate(out) if out else np.zeros((0, 5))


def focal(logit, heat, ignore):
    p = torch.sigmoid(logit).clamp(1e-4, 1 - 1e-4)
    pos = heat.eq(1).float() + (heat > 0.95).float() * (1 - heat.eq(1).float())
    neg = (1 - pos) * (1 - ignore)
    lp = -(torch.log(p) * (1 - p) ** 2 * pos).sum()
    ln = -(torch.log(1 - p) * p**2 * (1 - heat) ** 4 * neg).sum()
    return (lp + ln) / pos.sum().clamp(min=1)


def train(items, steps, seed, crop=160, batch=12, log=print, sim=(), sim_share=0.0, strong=False, mosaic_share=0.0,
          teachers=()):
    """`sim`: rendered frames (harvest-sim-frames), drawn for a share `sim_share` of each batch's samples.
    `teachers`: networks whose mean heatmap and mask probabilities the net also learns (distillation: the
    teachers' ensemble in one network's time); the boxes' losses stay."""
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    net = FruitNet()
    opt = torch.optim.AdamW(net.parameters(), lr=3e-3, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=3e-3, total_steps=steps, pct_start=0.1)
    net.train()
    t0 = time.time()
    for step in range(steps):
        xs, ts = [], []
        for _ in range(batch):
            pool = sim if sim and rng.random() < sim_share else items
            if pool is items and mosaic_share > 0 and rng.random() < mosaic_share:
                im, b = mosaic(items, crop, rng, strong)
            else:
                im, b = sample(pool[rng.integers(len(pool))], crop, rng, strong)
            xs.append(normalise(im))
            ts.append([torch.from_numpy(t) for t in targets(crop, crop, b)])
        x = torch.stack(xs)
        heat, diam, wd, mask, ignore = (torch.stack([t[i] for t in ts]) for i in range(5))
        out = net(x)
        lh = focal(out[:, 0], heat, ignore)
        ld = (F.smooth_l1_loss(out[:, 1], diam, reduction="none", beta=0.1) * wd).sum() / wd.sum().clamp(min=1)
        lm = (F.binary_cross_entropy_with_logits(out[:, 2], mask, reduction="none") * (1 - ignore)).mean()
        loss = lh + 2 * ld + lm
        if teachers:
            with torch.no_grad():
                tp = torch.stack([torch.sigmoid(t(x)[:, [0, 2]]) for t in teachers]).mean(0)
            # Weighted by the larger of the two probabilities: where both see background there is nothing to
            # learn (an unweighted sum over every cell outweighed the boxes' loss 100 to 1); per positive, as focal.
            sp = torch.sigmoid(out[:, 0]).detach()
            kh = F.binary_cross_entropy_with_logits(out[:, 0], tp[:, 0], reduction="none") * torch.maximum(sp, tp[:, 0])
            kh = (kh * (1 - ignore)).sum() / heat.eq(1).float().sum().clamp(min=1)
            km = (F.binary_cross_entropy_with_logits(out[:, 2], tp[:, 1], reduction="none") * (1 - ignore)).mean()
            loss = loss + kh + km
            if step % 100 == 0 or step == steps - 1:
                log(f"  step {step:5d} distillation: heat {kh.item():.3f} mask {km.item():.3f}")
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        if step % 100 == 0 or step == steps - 1:
            log(f"  step {step:5d} loss {loss.item():.3f} (heat {lh.item():.3f} diam {ld.item():.3f} "
                f"mask {lm.item():.3f}) {time.time() - t0:.0f} s")
    net.eval()
    return net


MERGE_WITHIN = 0.75  # learned_keys::merge_within (C++)


def decode(out, threshold=0.3, merge_within=MERGE_WITHIN):
    """Peaks of the heatmap above threshold (3x3 maximum) -> [(u, v, d, score)] in input pixels, strongest
    first; a weaker peak within merge_within of the larger radius from a kept one is the same fruit.
    Same rules as LearnedDetector::decode (C++)."""
    heat = torch.sigmoid(out[0])
    peak = F.max_pool2d(heat[None, None], 3, 1, 1)[0, 0]
    res = []
    for y, x in zip(*torch.nonzero((heat == peak) & (heat >= threshold), as_tuple=True)):
        y, x = int(y), int(x)
        y0, y1, x0, x1 = max(y - 1, 0), min(y + 2, heat.shape[0]), max(x - 1, 0), min(x + 2, heat.shape[1])
        w = heat[y0:y1, x0:x1]
        gy, gx = torch.meshgrid(torch.arange(y0, y1).float(), torch.arange(x0, x1).float(), indexing="ij")
        u = float((w * gx).sum() / w.sum() + 0.5) * STRIDE
        v = float((w * gy).sum() / w.sum() + 0.5) * STRIDE
        res.append((u, v, DIAM_SCALE * math.exp(float(out[1, y, x])), float(heat[y, x])))
    res.sort(key=lambda r: -r[3])  # stable: ties keep the row-major order, as the C++ does
    if merge_within <= 0:
        return res
    kept = []
    for r in res:
        if all(math.hypot(r[0] - k[0], r[1] - k[1]) >= merge_within * 0.5 * max(r[2], k[2]) for k in kept):
            kept.append(r)
    return kept


def match(dets, boxes):
    """Greedy one-to-one: a detection matches a box containing its centre (as box_evaluation.cpp does,
    centre-inside pairs first; the IoU alternative is left to harvest-detect --evaluate)."""
    used, pairs = set(), []
    for i, (u, v, d, s) in sorted(enumerate(dets), key=lambda e: -e[1][3]):
        best, bd = -1, 1e18
        for j, (x1, y1, x2, y2, _) in enumerate(boxes):
            if j in used or not (x1 <= u <= x2 and y1 <= v <= y2):
                continue
            dd = (u - (x1 + x2) / 2) ** 2 + (v - (y1 + y2) / 2) ** 2
            if dd < bd:
                best, bd = j, dd
        if best >= 0:
            used.add(best)
            pairs.append((i, best))
    return pairs


def pad4(img):
    h, w = img.shape[:2]
    return img[: h - h % STRIDE, : w - w % STRIDE]


THRESHOLDS = [round(0.15 + 0.05 * i, 2) for i in range(12)]  # 0.15 .. 0.70, the grid a threshold is chosen from


def predict(net, items, threshold=min(THRESHOLDS)):
    """Each item's detections at the lowest threshold of the grid (a higher one keeps a prefix: the merge
    only looks at stronger fruit)."""
    with torch.no_grad():
        return [decode(net(normalise(pad4(img))[None])[0], threshold) for _, img, _ in items]


def score(net, items, threshold=0.3, preds=None):
    """(true positives, detections, fruit, centre errors, diameter errors) at `threshold`."""
    tp = nd = nb = 0
    cerr, derr = [], []
    preds = preds if preds is not None else predict(net, items)
    for (_, img, boxes), all_dets in zip(items, preds):
        dets = [d for d in all_dets if d[3] >= threshold]
        pairs = match(dets, boxes)
        hidden = {j for _, j in pairs if boxes[j][4] < SCORED_VISIBLE}  # neither found nor missed
        pairs = [(i, j) for i, j in pairs if j not in hidden]
        tp = tp + len(pairs)
        nd = nd + len(dets) - len(hidden)
        nb = nb + int((boxes[:, 4] >= SCORED_VISIBLE).sum())
        for i, j in pairs:
            x1, y1, x2, y2, _ = boxes[j]
            u, v, d, _ = dets[i]
            bd = (x2 - x1 + y2 - y1) / 2
            cerr.append(math.hypot(u - (x1 + x2) / 2, v - (y1 + y2) / 2) / bd)
            derr.append(abs(d - bd) / bd)
    return tp, nd, nb, cerr, derr


def f1(tp, nd, nb):
    return 2 * tp / max(nd + nb, 1)


def best_threshold(counts):
    """The grid threshold of highest F1 over summed (tp, detections, fruit) per threshold; ties: the lower."""
    return max(THRESHOLDS, key=lambda t: (f1(*counts[t]), -t))


def export(net, path):
    net.eval()
    torch.onnx.export(net, torch.zeros(1, 3, 240, 320), path, opset_version=11, input_names=["image"],
                      output_names=["maps"], dynamic_axes={"image": {2: "h", 3: "w"}, "maps": {2: "h4", 3: "w4"}})


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="folder with boxes.csv and images/")
    ap.add_argument("--out", required=True, help="ONNX file to write")
    ap.add_argument("--width", type=int, default=320, help="photos are scaled to this width")
    ap.add_argument("--steps", type=int, default=1500)
    ap.add_argument("--folds", type=int, default=0, help="k-fold cross-validation first (0: none)")
    ap.add_argument("--seed", type=int, default=19)
    ap.add_argument("--train-seed", type=int, help="seed of the training runs (default --seed; the folds stay --seed's)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--folds-only", action="store_true", help="skip the final model on all photos")
    ap.add_argument("--sim", action="append", default=[],
                    help="folder of rendered frames (harvest-sim-frames) added to every model's training set")
    ap.add_argument("--sim-share", type=float, default=0.3, help="share of training samples drawn from --sim")
    ap.add_argument("--jitter", choices=("basic", "strong"), default="basic",
                    help="colour jitter: strong adds blur, gamma, wider saturation and white balance")
    ap.add_argument("--mosaic", type=float, default=0.0,
                    help="share of photo samples that are a 2x2 mosaic of four photos' crops (0: none)")
    ap.add_argument("--sim-test", help="folder of other rendered frames: every model is also scored on them")
    ap.add_argument("--teachers", action="append", default=[],
                    help="folder of a model trained with the same folds (its fruit_net.fold<k>.onnx for fold k, "
                         "fruit_net.onnx for the final model); each model also learns the teachers' mean maps")
    ap.add_argument("--teacher-seeds", default="",
                    help="comma-separated training seeds: before each model, train one teacher per seed on the same "
                         "photos (as --train-seed S would: fold k's with S + 1 + k) and distill them into it")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    random.seed(a.seed)
    items = load(a.data, a.width)
    print(f"{len(items)} photos, {sum(len(b) for _, _, b in items)} boxes, width {a.width}", flush=True)
    log = lambda s: print(s, flush=True)
    sim = [it for d in a.sim for it in load(d, a.width)]
    sim_test = load(a.sim_test, a.width) if a.sim_test else []
    if sim:
        log(f"{len(sim)} rendered frames, {sum(len(b) for _, _, b in sim)} fruit, {a.sim_share:.0%} of samples")

    def report(what, r):
        tp, nd, nb, ce, de = r
        R, P = tp / max(nb, 1), tp / max(nd, 1)
        log(f"{what}: R {R:.3f} P {P:.3f} F1 {2 * R * P / max(R + P, 1e-9):.3f} ({tp} of {nb} fruit, {nd} detections); "
            f"centre error median {np.median(ce) if ce else float('nan'):.3f} D, "
            f"diameter error median {np.median(de) if de else float('nan'):.3f} D")

    ts = a.seed if a.train_seed is None else a.train_seed
    def fit(photos, seed, teachers=()):
        return train(photos, a.steps, seed, log=log, sim=sim, sim_share=a.sim_share, strong=a.jitter == "strong",
                     mosaic_share=a.mosaic, teachers=teachers)

    def train_with(photos, name, offset=0):
        """A model (seed ts + offset: fold k's offset is 1 + k) on `photos`, distilled from the teachers given for
        it: the folders' model `name`, and one per --teacher-seeds S trained here (seed S + offset)."""
        teachers = [load_teacher(os.path.join(d, name)) for d in a.teachers]
        for s in (int(v) for v in a.teacher_seeds.split(",") if v.strip()):
            log(f"teacher, seed {s + offset}")
            teachers.append(fit(photos, s + offset))
        if teachers:
            log(f"distilling {len(teachers)} teachers")
        return fit(photos, ts + offset, teachers)

    if a.folds:
        order = list(range(len(items)))
        random.Random(a.seed).shuffle(order)
        tot = [0, 0, 0, [], []]
        fold_csv = os.path.join(os.path.dirname(os.path.abspath(a.out)), "folds.csv")
        with open(fold_csv, "w") as f:  # for harvest-detect --evaluate --fold-models
            f.write("image,model\n")
            for k in range(a.folds):
                for i in sorted(order[k :: a.folds]):
                    f.write(f"{items[i][0]},{os.path.basename(a.out).replace('.onnx', f'.fold{k}.onnx')}\n")
        per_fold = []  # per fold: {threshold: (tp, detections, fruit)} on its test photos
        for k in range(a.folds):
            test = [items[i] for i in sorted(order[k :: a.folds])]
            log(f"fold {k}: {len(test)} test photos: " + " ".join(it[0] for it in test))
            net = train_with([it for i, it in enumerate(items) if i not in set(order[k :: a.folds])],
                             f"fruit_net.fold{k}.onnx", offset=1 + k)
            export(net, a.out.replace(".onnx", f".fold{k}.onnx"))
            preds = predict(net, test)
            per_fold.append({t: score(net, test, t, preds)[:3] for t in THRESHOLDS})
            log(f"fold {k}: " + ", ".join(f"t {t}: R {c[0] / max(c[2], 1):.3f} P {c[0] / max(c[1], 1):.3f}"
                                          for t, c in per_fold[-1].items()))
            if sim_test:
                report(f"fold {k} on rendered frames (threshold 0.3)", score(net, sim_test))
        add = lambda cs: tuple(sum(c[i] for c in cs) for i in range(3))
        line = lambda what, c: log(f"{what}: R {c[0] / max(c[2], 1):.3f} P {c[0] / max(c[1], 1):.3f} "
                                   f"F1 {f1(*c):.3f} ({c[0]} of {c[2]} fruit, {c[1]} detections)")
        line(f"cross-validated ({a.folds}-fold), threshold 0.3", add([pf[0.3] for pf in per_fold]))
        # Nested: fold k's threshold is chosen on the other folds' held-out photos only (scored by their own
        # models, which did train on fold k's photos: fold k's boxes never choose its threshold).
        chosen = [best_threshold({t: add([pf[t] for j, pf in enumerate(per_fold) if j != k]) for t in THRESHOLDS})
                  for k in range(a.folds)]
        line(f"cross-validated, threshold chosen on the other folds ({', '.join(map(str, chosen))})",
             add([pf[t] for pf, t in zip(per_fold, chosen)]))
        with open(fold_csv, "w") as f:  # now with each fold's threshold
            f.write("image,model,threshold\n")
            for k in range(a.folds):
                for i in sorted(order[k :: a.folds]):
                    model = os.path.basename(a.out).replace(".onnx", f".fold{k}.onnx")
                    f.write(f"{items[i][0]},{model},{chosen[k]}\n")
        best = best_threshold({t: add([pf[t] for pf in per_fold]) for t in THRESHOLDS})
        log(f"threshold for the final model (best F1 over all folds' held-out photos): {best}"
            " (learned_keys::threshold; the figures at it over the same folds would be optimistic)")
    if a.folds_only:
        return
    net = train_with(items, "fruit_net.onnx")
    export(net, a.out)
    if sim_test:
        report("final model on rendered frames", score(net, sim_test))
    log(f"wrote {a.out} ({os.path.getsize(a.out)} bytes)")


if __name__ == "__main__":
    main()
