"""A real weavefitd on an ephemeral loopback port, for the Python tests.

`LoopbackDaemon(work_dir)` starts $WEAVEFITD with --listen 127.0.0.1:0
--port-file, its output in work_dir/weavefitd.log, and waits (30 s at most)
for the port file's first line, the gRPC port: `server` is then
"127.0.0.1:PORT". `stop()` gives it its 30 s shutdown grace, then kills it;
`log()` is what it wrote. Tests register `stop` (and `close`) as class
cleanups right after starting, so the daemon is stopped even when a test
fails.
"""
import os
import subprocess
import time


def _first_line(path):
    try:
        with open(path) as f:
            return f.readline().strip()
    except OSError:
        return ""


class LoopbackDaemon:
    def __init__(self, work_dir):
        port_file = os.path.join(work_dir, "port")
        self._log = open(os.path.join(work_dir, "weavefitd.log"), "w")
        self.process = subprocess.Popen(
            [os.environ["WEAVEFITD"], "--listen", "127.0.0.1:0", "--port-file", port_file],
            stdout=self._log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 30
        while not _first_line(port_file):
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError("weavefitd did not start:\n" + self.log())
            time.sleep(0.05)
        self.server = "127.0.0.1:" + _first_line(port_file)

    def poll(self):
        """None while the daemon runs, else its exit status (Popen.poll)."""
        return self.process.poll()

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=40)  # within the daemon's 30 s shutdown grace
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self._log.close()

    def log(self):
        if not self._log.closed:
            self._log.flush()
        with open(self._log.name) as f:
            return f.read()
