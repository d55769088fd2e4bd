#!/usr/bin/python3
"""Writes the fuzzers' seed corpus (committed under fuzz/corpus/):

  decode/   small photographs in every format weavefit reads, and broken ones
  request/  inputs for request_fuzzer: byte 0 selects the call and which of
            the fixed fields after it apply (roi, phase angle and diameter,
            mode), then those fields, then records of [2-byte little-endian
            length][serialised EstimateRequest] (see request_fuzzer.cc)

Run from the repository root after a build (it uses build/client/weavefit to
render and build/python/stubs for the messages):
    /usr/bin/python3 fuzz/make_seeds.py
"""
import os
import struct
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "build", "python", "stubs"))
from weavefit.v1 import weavefit_pb2 as pb  # noqa: E402

WEAVEFIT = os.path.join(ROOT, "build", "client", "weavefit")
CORPUS = os.path.join(ROOT, "fuzz", "corpus")


def render(path, fmt, width=64, height=48, extra=()):
    subprocess.run([WEAVEFIT, "render", "--out", path, "--format", fmt, "--width", str(width),
                    "--height", str(height), "--samples", "1", *extra], check=True,
                   stdout=subprocess.DEVNULL)
    with open(path, "rb") as f:
        return f.read()


ROI, GEOMETRY, MODE = 8, 16, 32  # byte 0's bits for the fixed fields


def fixed(flags=0, roi=(0, 0, 0, 0), phase=0.0, diameter=0.0, mode=0):
    """Byte 0 and the fixed fields request_fuzzer applies to every header."""
    return bytes([flags]) + struct.pack("<4i2di", *roi, phase, diameter, mode)


def record(message):
    data = message.SerializeToString()
    return struct.pack("<H", len(data)) + data


def header(phase=10.0, mode=pb.BALANCED, total=0, name="seed.png"):
    m = pb.EstimateRequest()
    m.header.acquisition.phase_angle_deg = phase
    m.header.acquisition.cylinder_diameter_mm = 46.0
    m.header.options.mode = mode
    m.header.filename = name
    m.header.total_bytes = total
    return m


def chunk(data):
    m = pb.EstimateRequest()
    m.chunk = data
    return m


def main():
    os.makedirs(os.path.join(CORPUS, "decode"), exist_ok=True)
    os.makedirs(os.path.join(CORPUS, "request"), exist_ok=True)
    images = {}
    with tempfile.TemporaryDirectory() as tmp:
        for fmt, ext in [("png", "png"), ("png8", "png"), ("tiff", "tiff"), ("exr", "exr"),
                         ("jpeg", "jpg")]:
            images[fmt] = render(os.path.join(tmp, f"seed_{fmt}.{ext}"), fmt)
        images["rgb"] = render(os.path.join(tmp, "rgb.png"), "png8",
                               extra=("--specular-rgb", "1", "0.6", "0.3"))
        # A cylinder big enough for the pipeline to run past detection.
        images["whole"] = render(os.path.join(tmp, "whole.png"), "png8", 160, 120)
    for name, data in images.items():
        with open(os.path.join(CORPUS, "decode", name), "wb") as f:
            f.write(data)
    png = images["png"]
    # A PNG whose header claims 100000 x 100000 pixels (CRC left stale: the
    # decoder must refuse it on the size, or on the CRC, before allocating).
    lying = bytearray(png)
    lying[16:24] = struct.pack(">II", 100000, 100000)
    broken = {"lying_header.png": bytes(lying), "truncated.png": png[: len(png) // 2],
              "signature_only.exr": images["exr"][:8]}
    for name, data in broken.items():
        with open(os.path.join(CORPUS, "decode", name), "wb") as f:
            f.write(data)

    whole = images["whole"]  # 160 x 120
    estimate = record(header(total=len(whole))) + b"".join(
        record(chunk(whole[i:i + 4096])) for i in range(0, len(whole), 4096))
    requests = {
        "estimate": fixed() + estimate,
        "estimate_fast": fixed() + record(header(mode=pb.FAST)) + record(chunk(whole)),
        "joint": fixed(1) + record(header(10.0)) + record(chunk(whole)) + record(header(60.0))
                 + record(chunk(whole)),
        "second_header": fixed() + record(header()) + record(header()),
        "no_header": fixed() + record(chunk(png)),
        "bad_phase": fixed() + record(header(phase=400.0)) + record(chunk(png)),
        "wrong_total": fixed() + record(header(total=12)) + record(chunk(png)),
        "fuzzed_token": fixed(2) + record(header()) + record(chunk(png)),
        # The fixed fields over an image that decodes: the estimator's
        # geometry within one mutation of any value (issue 30).
        "roi_whole": fixed(ROI, roi=(0, 0, 160, 120)) + estimate,
        "roi_inner": fixed(ROI, roi=(16, 8, 128, 100)) + estimate,
        "roi_joint": fixed(1 | ROI, roi=(8, 0, 144, 120)) + record(header(10.0))
                     + record(chunk(whole)) + record(header(60.0)) + record(chunk(whole)),
        "geometry": fixed(GEOMETRY, phase=30.0, diameter=46.0) + estimate,
        "mode_accurate": fixed(MODE, mode=pb.ACCURATE) + estimate,
        "mode_unknown": fixed(MODE, mode=99) + estimate,
        # The input that crashed weavefitd (issue 30), kept as a regression.
        "roi_overflow": fixed(ROI, roi=(2147483547, 0, 200, 100)) + estimate,
    }
    for name, data in requests.items():
        with open(os.path.join(CORPUS, "request", name), "wb") as f:
            f.write(data)
    print("seeds written to", CORPUS)


if __name__ == "__main__":
    main()
