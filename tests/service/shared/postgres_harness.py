"""A PostgreSQL 15 server of the test's own, for the Python tests of the shared service.

initdb in a temporary folder, run as the postgres user (runuser) when the test runs as root, on a
free port of 127.0.0.1; TCP logins need the password (scram-sha-256), which the daemons read from
a file. fsync is off: the tests kill daemons and stop the server, not the machine.
"""
import os
import pwd
import shutil
import socket
import subprocess
import tempfile

BIN = "/usr/lib/postgresql/15/bin"
USER = "rv"
PASSWORD = "rv-shared-test-9x"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Postgres:
    def __init__(self):
        self.dir = tempfile.mkdtemp(prefix="rv-pg-")
        self.as_postgres = os.geteuid() == 0
        if self.as_postgres:
            pw = pwd.getpwnam("postgres")
            os.chown(self.dir, pw.pw_uid, pw.pw_gid)
        self.password_file = os.path.join(self.dir, "pw")
        with open(self.password_file, "w") as f:
            f.write(PASSWORD + "\n")
        if self.as_postgres:
            os.chown(self.password_file, pwd.getpwnam("postgres").pw_uid, -1)
        self.data = os.path.join(self.dir, "data")
        self._run([f"{BIN}/initdb", "-D", self.data, "-U", USER, "-E", "UTF8", "--no-sync", "--auth-local=trust",
                   "--auth-host=scram-sha-256", f"--pwfile={self.password_file}"])
        self.port = free_port()
        self.start()

    def _run(self, argv, check=True):
        if self.as_postgres:
            argv = ["runuser", "-u", "postgres", "--"] + argv
        return subprocess.run(argv, check=check, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)

    def start(self):
        self._run([f"{BIN}/pg_ctl", "-D", self.data, "-l", os.path.join(self.dir, "server.log"), "-w", "-t", "60",
                   "-o", f"-p {self.port} -k {self.dir} -c listen_addresses=127.0.0.1 -c fsync=off "
                         f"-c max_connections=300", "start"])

    def stop(self):
        """Fast shutdown: connections are cut, as when an operator restarts the server."""
        self._run([f"{BIN}/pg_ctl", "-D", self.data, "-m", "fast", "-w", "stop"])

    def uri(self, db="postgres"):
        return f"postgresql://{USER}@127.0.0.1:{self.port}/{db}"

    def psql(self, sql, db="postgres"):
        """Runs SQL on the server's socket; returns the rows as lists of text."""
        argv = ["/usr/bin/psql", "-X", "-q", "-A", "-t", "-F", "\t", "-v", "ON_ERROR_STOP=1", "-h", self.dir,
                "-p", str(self.port), "-U", USER, "-d", db, "-c", sql]
        if self.as_postgres:
            argv = ["runuser", "-u", "postgres", "--"] + argv
        out = subprocess.run(argv, check=True, capture_output=True, text=True).stdout
        return [line.split("\t") for line in out.splitlines() if line]

    def close(self):
        self._run([f"{BIN}/pg_ctl", "-D", self.data, "-m", "immediate", "stop"], check=False)
        shutil.rmtree(self.dir, ignore_errors=True)
