"""NVIDIA's FLIP (the flip-evaluator package) of TEST against REF.
Usage: flip_mean.py REF TEST                 prints LDR-FLIP's mean error;
       flip_mean.py REF TEST HDR [START STOP] prints HDR-FLIP's mean error and
       the exposures it used, as one JSON object (START, STOP: given exposures)."""
import json
import os
import sys

import flip_evaluator

for path in sys.argv[1:3]:
    if not os.path.exists(path):
        sys.exit(f"{path}: no such file")
if len(sys.argv) > 3 and sys.argv[3] == "HDR":
    parameters = {}
    if len(sys.argv) > 5:
        parameters = {"startExposure": float(sys.argv[4]), "stopExposure": float(sys.argv[5])}
    _, mean, used = flip_evaluator.evaluate(sys.argv[1], sys.argv[2], "HDR", parameters=parameters)
    print(json.dumps({
        "mean": float(mean),
        "start": used["startExposure"],
        "stop": used["stopExposure"],
        "count": used["numExposures"],
    }))
else:
    _, mean, _ = flip_evaluator.evaluate(sys.argv[1], sys.argv[2], "LDR")
    print(repr(float(mean)))
