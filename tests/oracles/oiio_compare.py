"""OpenImageIO's own comparison of two images, at full precision: what idiff
computes and prints rounded. Usage: oiio_compare.py A B FAIL WARN [CHANNELS]
(CHANNELS: comma-separated names to keep first, as oiiotool --ch does).
Prints one JSON object; non-finite figures as the words idiff prints (inf, nan)."""
import json
import math
import sys

import OpenImageIO as oiio


def read(path, channels):
    buf = oiio.ImageBuf(path)
    if not buf.read(0, 0, True, oiio.FLOAT):
        sys.exit(f"{path}: {buf.geterror()}")
    if channels:
        buf = oiio.ImageBufAlgo.channels(buf, tuple(channels))
    return buf


def figure(v):
    return v if math.isfinite(v) else ("nan" if math.isnan(v) else "inf")


a_path, b_path, fail, warn = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
channels = sys.argv[5].split(",") if len(sys.argv) > 5 else None
a, b = read(a_path, channels), read(b_path, channels)
r = oiio.ImageBufAlgo.compare(a, b, fail, warn)
names = a.spec().channelnames + b.spec().channelnames[a.nchannels:]
print(json.dumps({
    "mean": figure(r.meanerror),
    "rms": figure(r.rms_error),
    "psnr": figure(r.PSNR),
    "max": figure(r.maxerror),
    "x": r.maxx,
    "y": r.maxy,
    "channel": names[r.maxc],
    "nwarn": r.nwarn,
    "nfail": r.nfail,
    "channels": list(names),
}))
