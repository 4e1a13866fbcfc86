"""OpenImageIO's own comparison of two images, at full precision: what idiff
computes and prints rounded. Usage: oiio_compare.py A B FAIL WARN [CHANNELS]
(CHANNELS: comma-separated names to keep first, as oiiotool --ch does).
Prints one JSON object."""
import json
import sys

import OpenImageIO as oiio


def read(path, channels):
    buf = oiio.ImageBuf(path)
    if not buf.read(0, 0, True, oiio.FLOAT):
        sys.exit(f"{path}: {buf.geterror()}")
    if channels:
        buf = oiio.ImageBufAlgo.channels(buf, tuple(channels))
    return buf


a_path, b_path, fail, warn = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
channels = sys.argv[5].split(",") if len(sys.argv) > 5 else None
a, b = read(a_path, channels), read(b_path, channels)
r = oiio.ImageBufAlgo.compare(a, b, fail, warn)
names = a.spec().channelnames + b.spec().channelnames[a.nchannels:]
print(json.dumps({
    "mean": r.meanerror,
    "rms": r.rms_error,
    "psnr": r.PSNR,
    "max": r.maxerror,
    "x": r.maxx,
    "y": r.maxy,
    "channel": names[r.maxc],
    "nwarn": r.nwarn,
    "nfail": r.nfail,
    "channels": list(names),
}))
