#!/usr/bin/python3
"""Writes the fuzzers' seed corpus (committed under fuzz/corpus/):

  decode/   small photographs in every format weavefit reads, and broken ones
  request/  inputs for request_fuzzer: byte 0 selects the call, then records
            of [2-byte little-endian length][serialised EstimateRequest]

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

    whole = images["whole"]
    requests = {
        "estimate": b"\x00" + record(header(total=len(whole))) + b"".join(
            record(chunk(whole[i:i + 4096])) for i in range(0, len(whole), 4096)),
        "estimate_fast": b"\x00" + record(header(mode=pb.FAST)) + record(chunk(whole)),
        "joint": b"\x01" + record(header(10.0)) + record(chunk(whole)) + record(header(60.0))
                 + record(chunk(whole)),
        "second_header": b"\x00" + record(header()) + record(header()),
        "no_header": b"\x00" + record(chunk(png)),
        "bad_phase": b"\x00" + record(header(phase=400.0)) + record(chunk(png)),
        "wrong_total": b"\x00" + record(header(total=12)) + record(chunk(png)),
        "fuzzed_token": b"\x02" + record(header()) + record(chunk(png)),
    }
    for name, data in requests.items():
        with open(os.path.join(CORPUS, "request", name), "wb") as f:
            f.write(data)
    print("seeds written to", CORPUS)


if __name__ == "__main__":
    main()
