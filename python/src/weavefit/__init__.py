"""weavefit: a Python client of weavefitd, the weavefit estimation daemon.

weavefit estimates the thread geometry of a woven cloth (profile model, peak
spacing, max slope, wavelength and amplitude, each with its standard error)
from one photograph of the cloth wrapped around a cylinder. This package
sends photographs to a running weavefitd over gRPC (weavefit.v1, whose
stubs, generated at build time, are importable as weavefit.v1.weavefit_pb2
and weavefit.v1.weavefit_pb2_grpc) and returns typed results:

    import weavefit

    with weavefit.Client("127.0.0.1:50051", timeout_s=60) as client:
        r = client.estimate("photo.png")  # acquisition from photo.json
        r = client.estimate(png_bytes, phase_angle_deg=10.0, diameter_mm=46.0)
        print(r.model, r.peak_spacing_deg.value, r.peak_spacing_deg.stderr)

Failures raise weavefit.EstimateError, whose .code is the grpc.StatusCode.
"""
from weavefit.client import (CHUNK_BYTES, MODES, RETRYABLE_CODES, Client, EstimateError,
                             Measurement, Result)

__all__ = ["Client", "EstimateError", "Measurement", "Result", "CHUNK_BYTES", "MODES",
           "RETRYABLE_CODES", "__version__"]
__version__ = "0.1.0"
