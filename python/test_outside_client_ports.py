#!/usr/bin/python3
"""What each of weavefitd's ports answers, asked by an outside client.

Run by ctest (test outside_client_ports) with Debian's /usr/bin/python3 and,
in the environment, WEAVEFITD (the daemon binary). The calls are made with raw
bytes, as a client that has no weavefit stubs would make them: Debian ships
no grpc_reflection or grpc_health module for Python.

Server reflection must answer on a loopback --listen, or anywhere with
--reflection, and nowhere else; the plaintext --health-listen port must serve
grpc.health.v1 and nothing more. A non-loopback address is 0.0.0.0 (what
IsLoopbackAddress calls non-loopback), reached through 127.0.0.1.
"""
import os
import shutil
import subprocess
import tempfile
import time
import unittest

import grpc

REFLECTION = "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"
LIST_SERVICES = b"\x3a\x00"  # ServerReflectionRequest{list_services: ""} (field 7)
HEALTH = "/grpc.health.v1.Health/Check"
SERVING = b"\x08\x01"  # HealthCheckResponse{status: SERVING}
ESTIMATE = "/weavefit.v1.WeaveFit/Estimate"
TIMEOUT_S = 10


def make_certificates(folder):
    """A CA and a server certificate for 127.0.0.1, made by openssl (EC keys)."""
    script = """set -e
ec='-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes'
openssl req -x509 $ec -keyout ca.key -out ca.pem -days 3650 -subj /CN=weavefit-test-ca
printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext
openssl req $ec -keyout server.key -out server.csr -subj /CN=localhost
openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 3650 \
    -extfile server.ext -out server.pem
"""
    subprocess.run(["/bin/sh", "-c", script], cwd=folder, check=True, capture_output=True)


def reflection(channel):
    """(status code, reply bytes) of a list_services request."""
    call = channel.stream_stream(REFLECTION)  # no serializers: bytes in, bytes out
    try:
        return grpc.StatusCode.OK, b"".join(call(iter([LIST_SERVICES]), timeout=TIMEOUT_S))
    except grpc.RpcError as error:
        return error.code(), b""


def estimate_code(channel):
    """The status of an Estimate call that sends nothing."""
    try:
        channel.stream_unary(ESTIMATE)(iter([]), timeout=TIMEOUT_S)
        return grpc.StatusCode.OK
    except grpc.RpcError as error:
        return error.code()


class Daemon:
    """A weavefitd child process; its ports come from --port-file."""

    def __init__(self, folder, flags):
        self.folder = folder
        port_file = os.path.join(folder, "ports")
        self.log_path = os.path.join(folder, "weavefitd.log")
        with open(self.log_path, "w") as log:
            self.process = subprocess.Popen(
                [os.environ["WEAVEFITD"], "--port-file", port_file, *flags],
                stdout=log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 30
        while not os.path.exists(port_file):
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError("weavefitd did not start:\n" + self.log())
            time.sleep(0.05)
        with open(port_file) as f:
            self.port, _, self.health_port = (int(line) for line in f.read().split())

    def log(self):
        with open(self.log_path) as f:
            return f.read()

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=40)  # within the daemon's shutdown grace
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


class OutsideClientPorts(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.mkdtemp(prefix="weavefit_outside_client_")
        cls.addClassCleanup(shutil.rmtree, cls.work, ignore_errors=True)
        make_certificates(cls.work)
        with open(os.path.join(cls.work, "ca.pem"), "rb") as f:
            cls.ca = f.read()

    def start(self, flags):
        folder = tempfile.mkdtemp(dir=self.work)
        daemon = Daemon(folder, flags)
        self.addCleanup(daemon.stop)
        return daemon

    def channel(self, port, tls=False):
        target = f"127.0.0.1:{port}"
        if tls:
            made = grpc.secure_channel(target, grpc.ssl_channel_credentials(self.ca))
        else:
            made = grpc.insecure_channel(target)
        self.addCleanup(made.close)
        return made

    def check(self, flags, reflection_on, tls=False):
        """The main port serves reflection as expected and says so in its
        start-up line; the health port serves health and nothing else."""
        daemon = self.start(flags + ["--health-listen", "0.0.0.0:0"])
        code, reply = reflection(self.channel(daemon.port, tls))
        if reflection_on:
            self.assertEqual(code, grpc.StatusCode.OK, daemon.log())
            self.assertIn(b"weavefit.v1.WeaveFit", reply)
        else:
            self.assertEqual(code, grpc.StatusCode.UNIMPLEMENTED, daemon.log())
        health = self.channel(daemon.health_port)
        self.assertEqual(health.unary_unary(HEALTH)(b"", timeout=TIMEOUT_S), SERVING)
        self.assertEqual(reflection(health)[0], grpc.StatusCode.UNIMPLEMENTED,
                         "the health port serves reflection")
        self.assertEqual(estimate_code(health), grpc.StatusCode.UNIMPLEMENTED,
                         "the health port serves WeaveFit")
        self.assertIn("reflection on" if reflection_on else "reflection off", daemon.log())

    def test_loopback_serves_reflection(self):
        self.check(["--listen", "127.0.0.1:0"], reflection_on=True)

    def test_insecure_remote_serves_no_reflection_unless_asked(self):
        self.check(["--listen", "0.0.0.0:0", "--insecure-remote"], reflection_on=False)

    def test_insecure_remote_with_the_flag_serves_reflection(self):
        self.check(["--listen", "0.0.0.0:0", "--insecure-remote", "--reflection"],
                   reflection_on=True)

    def test_tls_remote_serves_no_reflection_unless_asked(self):
        certificate = ["--tls-cert", os.path.join(self.work, "server.pem"),
                       "--tls-key", os.path.join(self.work, "server.key")]
        self.check(["--listen", "0.0.0.0:0", *certificate], reflection_on=False, tls=True)


if __name__ == "__main__":
    unittest.main(verbosity=2)
