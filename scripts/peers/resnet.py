#!/usr/bin/env python3
"""CPU inference time of the project's ResNet character classifiers, rebuilt in plain PyTorch.

The architecture is the project's (learn/src/resnet/dense.rs): a 7x7 stride-2 convolution with batch
norm and ReLU, 3x3 stride-2 max pooling, stages of basic blocks (the first block of every stage
after the first halves the resolution; a 1x1 projection where the shape changes), adaptive average
pooling, fully connected layers with ReLU (dropout is off at inference), then the class layer.

Presets (input [channels, height, width] as the project's model files record it):
    lite:  stem 16, stages (16,1) (32,1), hidden 64 32, input 40x32x40, 26 classes
    tiny:  stem 8,  stages (8,1) (16,1),  hidden 16,    input 40x32x40, 2 classes
    paper: stem 64, stages (64,3) (128,4) (256,6) (512,3), hidden 256 128, input 40x120x160, 26 classes

Prints one JSON line: median and quartiles of the time per sample at the given batch.

Copied from the shared peer benchmark (../shared/peers/resnet.py) for scripts/peers/resnet.sh;
`--density` added: the input's share of non-zero cells, as `braille bench --model` draws them
(a dense network's work does not depend on it); batch norm folded into the convolutions by
default (`--no-fold` keeps it), as our folded network runs it.
"""
import argparse, json, os, platform, statistics, time
import torch
import torch.nn as nn

PRESETS = {
    "lite": dict(stem=16, stages=[(16, 1), (32, 1)], hidden=[64, 32], input=(40, 32, 40), classes=26),
    "tiny": dict(stem=8, stages=[(8, 1), (16, 1)], hidden=[16], input=(40, 32, 40), classes=2),
    "paper": dict(stem=64, stages=[(64, 3), (128, 4), (256, 6), (512, 3)], hidden=[256, 128], input=(40, 120, 160), classes=26),
}


class Block(nn.Module):
    def __init__(self, cin, cout, stride):
        super().__init__()
        self.c1 = nn.Conv2d(cin, cout, 3, stride, 1, bias=False); self.b1 = nn.BatchNorm2d(cout)
        self.c2 = nn.Conv2d(cout, cout, 3, 1, 1, bias=False); self.b2 = nn.BatchNorm2d(cout)
        self.down = None
        if stride != 1 or cin != cout:
            self.down = nn.Sequential(nn.Conv2d(cin, cout, 1, stride, 0, bias=False), nn.BatchNorm2d(cout))

    def forward(self, x):
        y = torch.relu(self.b1(self.c1(x)))
        y = self.b2(self.c2(y))
        return torch.relu(y + (x if self.down is None else self.down(x)))


class ResNet(nn.Module):
    def __init__(self, p):
        super().__init__()
        c = p["stem"]
        layers = [nn.Conv2d(p["input"][0], c, 7, 2, 3, bias=False), nn.BatchNorm2d(c), nn.ReLU(), nn.MaxPool2d(3, 2, 1)]
        for k, (o, n) in enumerate(p["stages"]):
            for b in range(n):
                layers.append(Block(c, o, 2 if k > 0 and b == 0 else 1)); c = o
        layers += [nn.AdaptiveAvgPool2d(1), nn.Flatten()]
        for h in p["hidden"]:
            layers += [nn.Linear(c, h), nn.ReLU()]; c = h
        layers.append(nn.Linear(c, p["classes"]))
        self.net = nn.Sequential(*layers)

    def forward(self, x):
        return self.net(x)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--preset", choices=sorted(PRESETS), default="lite")
    ap.add_argument("--batch", type=int, default=1)
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--warmup", type=int, default=20)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--input", help="C,H,W instead of the preset's (e.g. 40,64,80)")
    ap.add_argument("--density", type=float, default=1.0, help="share of non-zero input cells (counts 1-4)")
    ap.add_argument("--no-fold", action="store_true",
                    help="keep batch norm as its own layers (by default each is folded into the convolution before it, as ours is)")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(0)
    p = dict(PRESETS[a.preset])
    if a.input:
        p["input"] = tuple(int(v) for v in a.input.split(","))
    net = ResNet(p).eval()
    if not a.no_fold:
        # batch norm folded into the convolution before it (torch.fx), as our model files run it:
        # the same work on both sides
        from torch.fx.experimental.optimization import fuse
        net = fuse(net)
        assert not any(isinstance(m, nn.BatchNorm2d) for m in net.modules()), "a batch norm was not folded"
    xs = [torch.randint(1, 5, (a.batch, *p["input"])).float() * (torch.rand(a.batch, *p["input"]) < a.density) for _ in range(8)]
    ts = []
    with torch.inference_mode():
        for i in range(a.warmup):
            net(xs[i % 8])
        for i in range(a.runs):
            t0 = time.perf_counter(); net(xs[i % 8]); ts.append(time.perf_counter() - t0)
    ts.sort()
    q = lambda f: ts[min(len(ts) - 1, int(f * len(ts)))]
    print(json.dumps(dict(fw="torch", model="resnet-" + a.preset, input=list(p["input"]), batch=a.batch, threads=torch.get_num_threads(),
                          density=a.density, batch_norm_folded=not a.no_fold, per_sample_ms=statistics.median(ts) * 1e3 / a.batch, q1_ms=q(0.25) * 1e3 / a.batch,
                          q3_ms=q(0.75) * 1e3 / a.batch, runs=a.runs, torch=torch.__version__,
                          python=platform.python_version(), loadavg=os.getloadavg()[0])), flush=True)


if __name__ == "__main__":
    main()
