"""A glintd child process on a free loopback port, for the Python tests of tests/kserve/.

Started with --port-file, which glintd writes only once it reports SERVING (its kernels are
warm); stopped with SIGTERM (then SIGKILL) when the `with` block ends.
"""
import os
import signal
import subprocess
import tempfile
import time

START_TIMEOUT_S = 600  # a cold kernel cache on a loaded 2-core machine takes minutes


class Glintd:
    def __init__(self, glintd_path, args):
        # GLINTD_UNDER_TEST runs the test against another glintd binary (e.g. an older build),
        # as tests/support/glintd_process.h's Glintd::Launch does for the C++ tests.
        glintd_path = os.environ.get("GLINTD_UNDER_TEST") or glintd_path
        self._dir = tempfile.TemporaryDirectory(prefix="glint_kserve_")
        self.port_file = os.path.join(self._dir.name, "port")
        self.log_path = os.path.join(self._dir.name, "glintd.log")
        self._log = open(self.log_path, "wb")
        self.process = subprocess.Popen(
            [glintd_path, "--listen", "127.0.0.1:0", "--port-file", self.port_file, "--quiet"]
            + list(args),
            stdout=self._log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        self.address = None

    def log(self):
        with open(self.log_path, "rb") as f:
            return f.read().decode(errors="replace")

    def __enter__(self):
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            if self.process.poll() is not None:  # a crash or a refused flag: say so at once
                raise RuntimeError(f"glintd exited before SERVING (exit status {self.process.returncode}):\n"
                                   + self.log())
            if os.path.exists(self.port_file):
                with open(self.port_file) as f:
                    port = f.read().strip()
                if port:
                    self.address = "127.0.0.1:" + port
                    return self
            time.sleep(0.05)
        self.__exit__(None, None, None)
        raise RuntimeError("glintd did not report SERVING in time:\n" + self.log())

    def __exit__(self, *exc):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self._log.close()
        self._dir.cleanup()
        return False
