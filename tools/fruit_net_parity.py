#!/usr/bin/python3
"""Writes the data of the learned-detector tests (tests/unit/vision/learned_detector_test.cpp):

- fruit_net_parity.png: a small deterministic test image (texture + an orange disc),
- fruit_net_parity.txt: the network's output on it computed by PyTorch from the ONNX file's own
  weights (Conv and Relu nodes run with torch.nn.functional, float32), "1 3 H W" then the values;
  the C++ test requires OpenCV dnn to give the same within 1e-4,
- wrong_shape.onnx: a valid ONNX net with 2 output maps at full resolution (a model of the wrong shape).

  /usr/bin/python3 tools/fruit_net_parity.py --model config/vision/models/fruit_net.onnx --out tests/unit/vision/data
  /usr/bin/python3 tools/fruit_net_parity.py --model config/vision/models/fruit_net_x4.onnx \
      --out tests/unit/vision/data --name fruit_net_x4_parity
Re-run whenever a committed model changes.
"""
import argparse
import os

import numpy as np
import onnx
import torch
import torch.nn.functional as F
from onnx import numpy_helper
from PIL import Image


def run_onnx_in_torch(model, x):
    """Evaluates a Conv/Relu chain (what tools/train_detector.py exports) with PyTorch."""
    g = model.graph
    w = {i.name: torch.from_numpy(numpy_helper.to_array(i).copy()) for i in g.initializer}
    vals = {g.input[0].name: x}
    for n in g.node:
        a = {at.name: onnx.helper.get_attribute_value(at) for at in n.attribute}
        if n.op_type == "Conv":
            pads = a.get("pads", [0, 0, 0, 0])
            assert pads[0] == pads[2] and pads[1] == pads[3], "asymmetric padding"
            bias = w[n.input[2]] if len(n.input) > 2 else None
            y = F.conv2d(vals[n.input[0]], w[n.input[1]], bias, stride=a.get("strides", [1, 1]),
                         padding=pads[:2], dilation=a.get("dilations", [1, 1]), groups=a.get("group", 1))
        elif n.op_type == "Relu":
            y = F.relu(vals[n.input[0]])
        else:
            raise SystemExit(f"node type {n.op_type} not handled: extend run_onnx_in_torch")
        vals[n.output[0]] = y
    return vals[g.output[0].name]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", required=True)
    ap.add_argument("--out", required=True, help="folder for the test data")
    ap.add_argument("--name", default="fruit_net_parity",
                    help="the output's file name (NAME.txt); another than the default writes only that file, for a "
                         "second model on the same image (the merged ensemble: fruit_net_x4_parity)")
    a = ap.parse_args()
    torch.set_num_threads(1)
    os.makedirs(a.out, exist_ok=True)
    rng = np.random.default_rng(19)
    h, w = 48, 64
    img = rng.integers(0, 256, (h, w, 3)).astype(np.float32)
    img = (img + np.roll(img, 1, 0) + np.roll(img, 1, 1)) / 3 * 0.5 + np.array([40, 110, 50]) * 0.5  # leafy noise
    ys, xs = np.mgrid[0:h, 0:w]
    img[(xs - 40) ** 2 + (ys - 22) ** 2 < 14**2] = [230, 140, 30]
    img = img.astype(np.uint8)
    first = a.name == "fruit_net_parity"
    if first:
        Image.fromarray(img).save(os.path.join(a.out, "fruit_net_parity.png"))
    x = torch.from_numpy(img.astype(np.float32) / 127.5 - 1.0).permute(2, 0, 1)[None]
    with torch.no_grad():
        y = run_onnx_in_torch(onnx.load(a.model), x)
    with open(os.path.join(a.out, a.name + ".txt"), "w") as f:
        f.write(" ".join(str(s) for s in y.shape) + "\n")
        f.write("\n".join(f"{v:.9g}" for v in y.flatten().tolist()) + "\n")
    print(f"output {tuple(y.shape)}, range {float(y.min()):.4f} .. {float(y.max()):.4f}")
    if not first:
        return
    torch.onnx.export(torch.nn.Conv2d(3, 2, 1), torch.zeros(1, 3, 64, 64), os.path.join(a.out, "wrong_shape.onnx"),
                      opset_version=11, input_names=["image"], output_names=["maps"],
                      dynamic_axes={"image": {2: "h", 3: "w"}, "maps": {2: "h", 3: "w"}})


if __name__ == "__main__":
    main()
