#!/usr/bin/python3
"""Merges K fruit networks of the same architecture (tools/train_detector.py exports: a chain of Conv and Relu
nodes) into one ONNX network whose output is the mean of their outputs (an ensemble, docs/perception.md "Seed
ensembles and distillation"). The first convolutions are stacked (K times the output channels), every later
one becomes a grouped convolution (group K: each member sees only its own channels), and the 1x1 head sums the
members' channels with weights / K. The graph stays Conv and Relu only, so OpenCV dnn and the C++ detector load
it as any model: nothing in C++ knows it is an ensemble. Costs K times one model's arithmetic.

  /usr/bin/python3 tools/merge_models.py --out config/vision/models/fruit_net_x4.onnx A.onnx B.onnx C.onnx D.onnx

It checks its own output: the merged network on a random input equals the mean of the members within 1e-4.
"""
import argparse

import numpy as np
import onnx
import torch
from onnx import helper, numpy_helper

from fruit_net_parity import run_onnx_in_torch


def chain(model):
    """[(op, weight, bias, attributes)] of a Conv/Relu chain."""
    w = {i.name: numpy_helper.to_array(i) for i in model.graph.initializer}
    out = []
    for n in model.graph.node:
        at = {a.name: helper.get_attribute_value(a) for a in n.attribute}
        if n.op_type == "Relu":
            out.append(("Relu", None, None, {}))
        elif n.op_type == "Conv" and at.get("group", 1) == 1:
            out.append(("Conv", w[n.input[1]], w[n.input[2]], at))
        else:
            raise SystemExit(f"node {n.op_type} (group {at.get('group', 1)}) not handled: a plain exported FruitNet")
    return out


def merge(models):
    k = len(models)
    chains = [chain(m) for m in models]
    if any([(op, None if wt is None else wt.shape, at) for op, wt, _, at in c] !=
           [(op, None if wt is None else wt.shape, at) for op, wt, _, at in chains[0]] for c in chains):
        raise SystemExit("the models differ in architecture")
    convs = [i for i, (op, *_) in enumerate(chains[0]) if op == "Conv"]
    nodes, inits, x = [], [], "image"
    for i, (op, _, _, at) in enumerate(chains[0]):
        y = f"t{i}"
        if op == "Relu":
            nodes.append(helper.make_node("Relu", [x], [y]))
        else:
            ws = [c[i][1] for c in chains]
            bs = [c[i][2] for c in chains]
            attrs = dict(at)
            if i == convs[0]:  # every member reads the image: stack the output channels
                wt, b = np.concatenate(ws), np.concatenate(bs)
            elif i == convs[-1]:  # the head: the mean of the members' maps
                wt, b = np.concatenate(ws, axis=1) / k, np.mean(bs, axis=0)
            else:  # member j's channels to member j's channels
                wt, b = np.concatenate(ws), np.concatenate(bs)
                attrs["group"] = k
            inits += [numpy_helper.from_array(wt.astype(np.float32), f"w{i}"),
                      numpy_helper.from_array(b.astype(np.float32), f"b{i}")]
            nodes.append(helper.make_node("Conv", [x, f"w{i}", f"b{i}"], [y], **attrs))
        x = y
    nodes[-1].output[0] = models[0].graph.output[0].name
    src = models[0].graph
    graph = helper.make_graph(nodes, f"fruit_net_x{k}", [src.input[0]], [src.output[0]], inits)
    merged = helper.make_model(graph, opset_imports=models[0].opset_import)
    merged.ir_version = models[0].ir_version
    onnx.checker.check_model(merged)
    return merged


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("models", nargs="+")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    torch.set_num_threads(1)
    models = [onnx.load(p) for p in a.models]
    merged = merge(models)
    x = torch.randn(1, 3, 96, 128, generator=torch.Generator().manual_seed(19))
    with torch.no_grad():
        want = torch.stack([run_onnx_in_torch(m, x) for m in models]).mean(0)
        got = run_onnx_in_torch(merged, x)
    err = float((got - want).abs().max())
    if err > 1e-4:
        raise SystemExit(f"merged network differs from the members' mean by {err}")
    onnx.save(merged, a.out)
    print(f"wrote {a.out}: {len(models)} models, max difference from their mean {err:.1e}")


if __name__ == "__main__":
    main()
