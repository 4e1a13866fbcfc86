"""NVIDIA's LDR-FLIP (the flip-evaluator package) of TEST against REF: prints
its mean error. Usage: flip_mean.py REF TEST"""
import os
import sys

import flip_evaluator

for path in sys.argv[1:3]:
    if not os.path.exists(path):
        sys.exit(f"{path}: no such file")
_, mean, _ = flip_evaluator.evaluate(sys.argv[1], sys.argv[2], "LDR")
print(repr(float(mean)))
