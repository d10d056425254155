"""An S3-compatible server of the test's own, for the Python tests of the shared service.

s3rver (npm, tests/service/shared/package.json, installed by tools/setup.sh) on a free port of
127.0.0.1, its objects in a temporary folder, one bucket made at start. `env` gives the daemons
GDAL's /vsis3/ settings for it (path-style addressing, plain HTTP, s3rver's fixed keys); `keys()`
lists the bucket through GDAL as a daemon sees it.
"""
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time

from postgres_harness import free_port

HERE = os.path.dirname(os.path.abspath(__file__))
BIN = os.path.join(HERE, "node_modules", ".bin", "s3rver")


class S3:
    def __init__(self, bucket="rv"):
        if not os.path.exists(BIN):
            raise RuntimeError(f"{BIN} is missing: run tools/setup.sh")
        self.bucket = bucket
        self.dir = tempfile.mkdtemp(prefix="rv-s3-")
        self.port = free_port()
        self.proc = None
        self.start(["--configure-bucket", bucket])
        self.env = {"AWS_S3_ENDPOINT": f"127.0.0.1:{self.port}", "AWS_HTTPS": "NO", "AWS_VIRTUAL_HOSTING": "FALSE",
                    "AWS_ACCESS_KEY_ID": "S3RVER", "AWS_SECRET_ACCESS_KEY": "S3RVER", "AWS_REGION": "us-east-1"}

    def start(self, extra=()):
        """Starts s3rver on the folder and port (again, after stop()) and waits until it answers."""
        self.proc = subprocess.Popen([BIN, "-d", self.dir, "-p", str(self.port), "-a", "127.0.0.1", *extra,
                                      "--silent"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        end = time.time() + 60  # a loaded machine starts Node.js slowly
        while time.time() < end:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                return
            except OSError:
                time.sleep(0.05)
        raise RuntimeError("s3rver did not start")

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(timeout=10)

    def keys(self, prefix):
        """Every object key below s3://bucket/prefix, relative to it, asked afresh."""
        from osgeo import gdal
        for k, v in self.env.items():
            gdal.SetConfigOption(k, v)
        gdal.VSICurlClearCache()
        names = gdal.ReadDirRecursive(f"/vsis3/{self.bucket}/{prefix}") or []
        return sorted(n for n in names if not n.endswith("/"))

    def close(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.dir, ignore_errors=True)
