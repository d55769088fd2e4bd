"""weavefit.Client: one photograph in, one typed estimate out.

The Estimate call of weavefit.v1 (proto/weavefit/v1/weavefit.proto): a
RequestHeader (acquisition, options, file name, total size), then the file in
chunks of at most 1 MiB; the reply comes when the stream is closed. This
module wraps it with the deadline, retries with exponential backoff on
UNAVAILABLE, RESOURCE_EXHAUSTED and DEADLINE_EXCEEDED, a bearer token, TLS,
the sidecar convention of `weavefit submit`, and typed results.
"""
from __future__ import annotations

import json
import os
import random
import time
from dataclasses import asdict, dataclass, field, fields
from typing import Any, Dict, List, Optional, Tuple, Union

import grpc

try:
    from weavefit.v1 import weavefit_pb2 as pb
    from weavefit.v1 import weavefit_pb2_grpc as pb_grpc
except ImportError as e:  # the source tree, not an installed package
    raise ImportError(
        "weavefit: no generated weavefit.v1 stubs; install the package (they are generated "
        "at build time): python3 -m pip install --no-build-isolation ./python") from e

__all__ = ["Client", "EstimateError", "Measurement", "Result", "CHUNK_BYTES", "MODES",
           "RETRYABLE_CODES"]

CHUNK_BYTES = 1 << 20  # the contract's largest chunk
MODES = ("fast", "balanced", "accurate")
RETRYABLE_CODES = frozenset({grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.RESOURCE_EXHAUSTED,
                             grpc.StatusCode.DEADLINE_EXCEEDED})
MAX_BACKOFF_S = 10.0

PathLike = Union[str, "os.PathLike[str]"]


class EstimateError(Exception):
    """A photograph that was not estimated: a gRPC status code and a message.

    Raised for the daemon's refusals (code as it answered, after any
    retries) and for what fails before a call: no phase angle
    (INVALID_ARGUMENT) or an unreadable file (NOT_FOUND).
    """

    def __init__(self, code: grpc.StatusCode, message: str) -> None:
        super().__init__(f"{code.name}: {message}")
        self.code: grpc.StatusCode = code
        self.message: str = message


@dataclass(frozen=True)
class Measurement:
    """One measured quantity (weavefit.v1.Measurement).

    When `resolved` is False the photograph does not support a value: `value`
    and `stderr` are 0 and meaningless, and `upper_bound` (0 = none) is what
    it does support. stderr² = statistical² + systematic².
    """

    value: float
    stderr: float
    resolved: bool
    upper_bound: float
    statistical: float
    systematic: float

    @classmethod
    def from_proto(cls, m: Any) -> "Measurement":
        return cls(value=m.value, stderr=m.stderr, resolved=m.resolved,
                   upper_bound=m.upper_bound, statistical=m.statistical,
                   systematic=m.systematic)

    def __str__(self) -> str:
        if self.resolved:
            return f"{self.value:.6g} ± {self.stderr:.2g}"
        return f"unresolved, ≤ {self.upper_bound:.4g}" if self.upper_bound > 0 else "unresolved"


def _enum_name(enum: Any, number: int) -> str:
    try:
        return str(enum.Name(number))
    except ValueError:  # a value newer than these stubs
        return str(number)


@dataclass(frozen=True)
class Result:
    """One photograph's estimate (weavefit.v1.EstimateReply), typed.

    `model` is "SMOOTH", "SINUSOID" or "SAWTOOTH"; `mode` is "fast",
    "balanced" or "accurate"; `version` is the daemon's. The acquisition as
    the daemon received it is in `phase_angle_deg`, `diameter_mm` (0 = not
    given: then wavelength and amplitude are unresolved, their values in
    cylinder radii in a warning) and `distance_mm` (0 = orthographic).
    Everything else (cylinder, candidates, timings, channels) is in `reply`,
    the raw protobuf.
    """

    model: str
    peak_spacing_deg: Measurement
    max_slope: Measurement
    max_inclination_deg: Measurement
    wavelength_mm: Measurement
    amplitude_mm: Measurement
    specular_azimuth_deg: Measurement
    warnings: List[str]
    filename: str
    sample_name: str
    version: str
    mode: str
    phase_angle_deg: float
    diameter_mm: float
    distance_mm: float
    reply: Any = field(repr=False, compare=False)

    @classmethod
    def from_reply(cls, reply: Any) -> "Result":
        return cls(
            model=_enum_name(pb.ProfileModel, reply.model),
            peak_spacing_deg=Measurement.from_proto(reply.peak_spacing_deg),
            max_slope=Measurement.from_proto(reply.max_slope),
            max_inclination_deg=Measurement.from_proto(reply.max_inclination_deg),
            wavelength_mm=Measurement.from_proto(reply.wavelength_mm),
            amplitude_mm=Measurement.from_proto(reply.amplitude_mm),
            specular_azimuth_deg=Measurement.from_proto(reply.specular_azimuth_deg),
            warnings=list(reply.warnings),
            filename=reply.filename,
            sample_name=reply.sample_name,
            version=reply.version,
            mode=_enum_name(pb.Mode, reply.mode).lower() if reply.mode else "",
            phase_angle_deg=reply.acquisition.phase_angle_deg,
            diameter_mm=reply.acquisition.cylinder_diameter_mm,
            distance_mm=reply.acquisition.camera_distance_mm,
            reply=reply)

    def to_dict(self) -> Dict[str, Any]:
        """Every field but `reply`, measurements as dicts: ready for json.dumps."""
        out: Dict[str, Any] = {}
        for f in fields(self):
            if f.name == "reply":
                continue
            v = getattr(self, f.name)
            out[f.name] = asdict(v) if isinstance(v, Measurement) else (
                list(v) if isinstance(v, list) else v)
        return out


def _read_sidecar(path: str) -> Tuple[str, Optional[Dict[str, Any]]]:
    """The sidecar IMAGE-stem.json's acquisition object, or None when there is none."""
    sidecar = os.path.splitext(path)[0] + ".json"
    try:
        with open(sidecar, encoding="utf-8") as f:
            doc = json.load(f)
    except FileNotFoundError:
        return sidecar, None
    except (OSError, ValueError) as e:
        raise EstimateError(grpc.StatusCode.INVALID_ARGUMENT,
                            f"cannot read the sidecar {sidecar}: {e}") from e
    acquisition = doc.get("acquisition") if isinstance(doc, dict) else None
    return sidecar, acquisition if isinstance(acquisition, dict) else {}


def _number(acquisition: Dict[str, Any], key: str, sidecar: str) -> Optional[float]:
    value = acquisition.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise EstimateError(grpc.StatusCode.INVALID_ARGUMENT,
                            f"{sidecar}: acquisition.{key} is not a number: {value!r}")
    return float(value)


class Client:
    """A connection to one weavefitd.

        with weavefit.Client("127.0.0.1:50051") as client:
            result = client.estimate("fixtures/gauze_sinusoid_p10.png")
            print(result.model, result.peak_spacing_deg)

    `target` is "host:port". `tls_ca` is the PEM file of the CA that signed
    the daemon's certificate and turns TLS on; `token_file`'s first line is
    sent as `authorization: Bearer <token>` metadata. `timeout_s` is each
    attempt's deadline; `retries` is how many times a call that failed with
    UNAVAILABLE, RESOURCE_EXHAUSTED or DEADLINE_EXCEEDED is tried again,
    after `backoff_s`, then twice that, and so on (up to 10 s, jittered).
    """

    def __init__(self, target: str, tls_ca: Optional[PathLike] = None,
                 token_file: Optional[PathLike] = None, timeout_s: float = 120.0,
                 retries: int = 3, backoff_s: float = 0.5) -> None:
        if timeout_s <= 0:
            raise ValueError(f"timeout_s must be > 0, got {timeout_s}")
        if retries < 0:
            raise ValueError(f"retries must be >= 0, got {retries}")
        self.target = target
        self.timeout_s = float(timeout_s)
        self.retries = int(retries)
        self.backoff_s = float(backoff_s)
        self._metadata: Tuple[Tuple[str, str], ...] = ()
        if token_file is not None:
            with open(token_file, encoding="utf-8") as f:  # the first line, as the CLI
                token = f.readline().strip()
            if not token:
                raise ValueError(f"token_file {os.fspath(token_file)}: the first line is empty")
            self._metadata = (("authorization", "Bearer " + token),)
        if tls_ca is not None:
            with open(tls_ca, "rb") as f:
                credentials = grpc.ssl_channel_credentials(root_certificates=f.read())
            self._channel = grpc.secure_channel(target, credentials)
        else:
            self._channel = grpc.insecure_channel(target)
        self._stub = pb_grpc.WeaveFitStub(self._channel)  # type: ignore[no-untyped-call]

    def close(self) -> None:
        """Closes the channel; calls after it fail."""
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc_info: Any) -> None:
        self.close()

    def estimate(self, image: Union[PathLike, bytes], phase_angle_deg: Optional[float] = None,
                 diameter_mm: Optional[float] = None, distance_mm: float = 0.0,
                 mode: str = "balanced", sample_name: Optional[str] = None,
                 filename: Optional[str] = None) -> Result:
        """Estimates one photograph: a path, or the encoded file's bytes.

        Without `phase_angle_deg`, a path's sidecar (same stem, .json) gives
        acquisition.phaseAngleDeg, and cylinderDiameterMm and
        cameraDistanceMm where `diameter_mm` is None and `distance_mm` is 0;
        with it, no sidecar is read. No phase angle at all raises
        EstimateError(INVALID_ARGUMENT). A diameter of None or 0 is sent as
        not given. `filename` (default: the path's base name) and
        `sample_name` (default: the file name) are echoed in the result.
        Raises EstimateError when the photograph is not estimated.
        """
        if mode.lower() not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        if isinstance(image, (bytes, bytearray, memoryview)):
            data, path = bytes(image), None
        else:
            path = os.fspath(image)
            try:
                with open(path, "rb") as f:
                    data = f.read()
            except OSError as e:
                raise EstimateError(grpc.StatusCode.NOT_FOUND,
                                    f"cannot read {path}: {e.strerror}") from e
        name = filename if filename is not None else (os.path.basename(path) if path else "")

        if phase_angle_deg is None and path is not None:
            sidecar, known = _read_sidecar(path)
            if known is not None:
                phase_angle_deg = _number(known, "phaseAngleDeg", sidecar)
                if diameter_mm is None:
                    diameter_mm = _number(known, "cylinderDiameterMm", sidecar)
                if not distance_mm:
                    distance_mm = _number(known, "cameraDistanceMm", sidecar) or 0.0
        if phase_angle_deg is None:
            where = (f"or a sidecar {os.path.splitext(path)[0]}.json with "
                     "acquisition.phaseAngleDeg" if path is not None else "(bytes have no sidecar)")
            raise EstimateError(grpc.StatusCode.INVALID_ARGUMENT,
                                f"no phase angle for {path or name or 'the image'}: "
                                f"give phase_angle_deg {where}")

        header = pb.RequestHeader(
            acquisition=pb.Acquisition(phase_angle_deg=float(phase_angle_deg),
                                       cylinder_diameter_mm=float(diameter_mm or 0.0),
                                       camera_distance_mm=float(distance_mm or 0.0)),
            options=pb.EstimateOptions(mode=pb.Mode.Value(mode.upper())),
            filename=name, sample_name=sample_name if sample_name is not None else name,
            total_bytes=len(data))
        return Result.from_reply(self._call(header, data))

    def _call(self, header: Any, data: bytes) -> Any:
        """The Estimate call, retried on the retryable codes with backoff."""

        def requests() -> Any:
            yield pb.EstimateRequest(header=header)
            for at in range(0, len(data), CHUNK_BYTES):
                yield pb.EstimateRequest(chunk=data[at:at + CHUNK_BYTES])

        attempt = 0
        while True:
            try:
                return self._stub.Estimate(requests(), timeout=self.timeout_s,
                                           metadata=self._metadata)
            except grpc.RpcError as e:
                code = e.code() if hasattr(e, "code") else grpc.StatusCode.UNKNOWN
                details = (e.details() if hasattr(e, "details") else None) or str(e)
                if code not in RETRYABLE_CODES or attempt >= self.retries:
                    tried = f" (after {attempt + 1} attempts)" if attempt else ""
                    raise EstimateError(code, details + tried) from None
            delay = min(MAX_BACKOFF_S, self.backoff_s * 2 ** attempt)
            time.sleep(delay * random.uniform(0.5, 1.0))
            attempt += 1
