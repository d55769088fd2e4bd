#!/usr/bin/env python3
"""Estimate one photograph with the weavefit package and print the result.

    python examples/estimate_one.py HOST:PORT IMAGE [--phase-angle DEG]
                                    [--diameter-mm MM] [--mode MODE] [--json]
                                    [--tls-ca PEM] [--token-file FILE]

Run it with the interpreter the package is installed in (e.g. a venv's
bin/python). Without --phase-angle the acquisition comes from IMAGE's
sidecar (IMAGE-stem.json). Exit status: 0, else the failure's gRPC code.
"""
import argparse
import json
import sys

import weavefit


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("server", help="weavefitd address, host:port")
    p.add_argument("image", help="photograph (png, tiff, jpeg, exr)")
    p.add_argument("--phase-angle", type=float, help="signed phase angle, deg")
    p.add_argument("--diameter-mm", type=float, help="cylinder diameter, mm")
    p.add_argument("--mode", choices=weavefit.MODES, default="balanced")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--tls-ca", help="CA certificate (PEM) of the daemon; turns TLS on")
    p.add_argument("--token-file", help="file whose first line is a bearer token")
    args = p.parse_args()

    try:
        with weavefit.Client(args.server, tls_ca=args.tls_ca, token_file=args.token_file) as c:
            r = c.estimate(args.image, phase_angle_deg=args.phase_angle,
                           diameter_mm=args.diameter_mm, mode=args.mode)
    except weavefit.EstimateError as e:
        print(f"estimate_one: {e}", file=sys.stderr)
        return int(e.code.value[0])
    if args.json:
        print(json.dumps(r.to_dict(), indent=2, ensure_ascii=False))
        return 0
    print(f"{r.filename}: {r.model} ({r.mode}, weavefitd {r.version})")
    for name in ("peak_spacing_deg", "max_slope", "max_inclination_deg", "wavelength_mm",
                 "amplitude_mm", "specular_azimuth_deg"):
        print(f"  {name:22} {getattr(r, name)}")
    for warning in r.warnings:
        print(f"  warning: {warning}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
