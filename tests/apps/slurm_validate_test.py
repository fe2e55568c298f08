"""Issue #52: `kcrig validate` as a real Slurm job, requeued mid-way.

Starts a one-node Slurm cluster of its own (munged, slurmctld and slurmd
from Debian's packages, configured here, on free loopback ports, all state
in a temporary folder), submits scripts/slurm/validate.sbatch on two tasks
(srun starts the ranks through PMIx), requeues the job (`scontrol requeue`:
Slurm kills it, as on preemption, and starts it again once the killed run's
credential has expired: cred_expire, 10 s here, 120 s by default) once its checkpoint
keeps a third of the cases, and checks that the job completes after its
restart with a validate.json byte for byte that of an uninterrupted run
without Slurm.

usage: slurm_validate_test.py KCRIG SOURCE_DIR WORK_DIR
"""
import os
import pathlib
import shutil
import socket
import subprocess
import sys
import time

CASES = ["--cases", "10", "--effects", "none,rig_compliance", "--seed", "3"]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(what, condition, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.2)
    raise SystemExit(f"FAIL: timed out waiting for {what}")


class Cluster:
    """munged, slurmctld and slurmd in `work`, stopped on exit."""

    def __init__(self, work):
        self.work = work
        self.daemons = []
        self.conf = work / "slurm.conf"
        self.env = dict(os.environ, SLURM_CONF=str(self.conf))

    def start(self):
        socket_path = self.work / "munge.socket"
        key = self.work / "munge.key"
        subprocess.run(["mungekey", "--create", f"--keyfile={key}"],
                       check=True)
        os.chmod(key, 0o600)
        self.spawn(["munged", "--foreground", "--force",
                    f"--socket={socket_path}", f"--key-file={key}",
                    f"--pid-file={self.work / 'munged.pid'}",
                    f"--seed-file={self.work / 'munge.seed'}",
                    f"--log-file={self.work / 'munged.log'}"])
        wait_for("munged", socket_path.exists, 20)
        (self.work / "state").mkdir()
        (self.work / "spool").mkdir()
        w = self.work
        self.conf.write_text(f"""ClusterName=kcrigtest
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
AuthType=auth/munge
AuthInfo=socket={socket_path},cred_expire=10
CredType=cred/munge
StateSaveLocation={w}/state
SlurmdSpoolDir={w}/spool
SlurmctldPidFile={w}/slurmctld.pid
SlurmdPidFile={w}/slurmd.pid
SlurmctldLogFile={w}/slurmctld.log
SlurmdLogFile={w}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobRequeue=1
KillWait=5
NodeName=localhost NodeAddr=127.0.0.1 CPUs={os.cpu_count()} State=UNKNOWN
PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE
""")
        self.spawn(["slurmctld", "-D", "-i", "-f", str(self.conf)])
        self.spawn(["slurmd", "-D", "-N", "localhost", "-f", str(self.conf)])
        wait_for("an idle node",
                 lambda: "idle" in self.run(["sinfo", "-h", "-o", "%t"]), 60)

    def spawn(self, command):
        self.daemons.append(subprocess.Popen(
            command, env=self.env, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, start_new_session=True))

    def run(self, command):
        done = subprocess.run(command, env=self.env, capture_output=True,
                              text=True)
        return done.stdout + done.stderr

    def job(self, job_id):
        """scontrol show job as key -> value."""
        fields = {}
        for word in self.run(["scontrol", "-o", "show", "job",
                              job_id]).split():
            key, _, value = word.partition("=")
            fields[key] = value
        return fields

    def stop(self):
        for daemon in reversed(self.daemons):
            daemon.terminate()
        for daemon in self.daemons:
            try:
                daemon.wait(timeout=20)
            except subprocess.TimeoutExpired:
                daemon.kill()

    def logs(self):
        text = ""
        for name in ("slurmctld.log", "slurmd.log", "munged.log"):
            path = self.work / name
            if path.exists():
                text += f"--- {name} (end)\n" + "".join(
                    path.read_text(errors="replace").splitlines(True)[-15:])
        return text


def ended(cluster, job_id):
    return cluster.job(job_id).get("JobState") in (
        "COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL")


def kept(folder):
    if not folder.is_dir():
        return 0
    return sum(1 for p in folder.iterdir() if p.name.startswith("item-"))


def main():
    kcrig = str(pathlib.Path(sys.argv[1]).resolve())
    source, work = pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
    for tool in ("slurmctld", "slurmd", "sbatch", "munged", "mungekey"):
        if shutil.which(tool) is None:
            raise SystemExit(f"FAIL: {tool} not installed (scripts/setup.sh)")
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    subprocess.run([kcrig, "validate", "--quiet", *CASES, "--out",
                    str(work / "alone.json")], check=True,
                   stdout=subprocess.DEVNULL)
    expected = (work / "alone.json").read_bytes()

    cluster = Cluster(work)
    try:
        cluster.start()
        out = work / "slurm.json"
        checkpoint = pathlib.Path(str(out) + ".checkpoint")
        submitted = cluster.run([
            "sbatch", "--parsable", "--ntasks=2", f"--chdir={work}",
            f"--output={work}/job-%j.out", f"--export=ALL,KCRIG={kcrig}",
            str(source / "scripts/slurm/validate.sbatch"), str(out), *CASES])
        job_id = submitted.strip().split(";")[0]
        if not job_id.isdigit():
            raise SystemExit(f"FAIL: sbatch: {submitted}")
        wait_for("a third of the cases kept",
                 lambda: kept(checkpoint) >= 3 or ended(cluster, job_id), 300)
        if ended(cluster, job_id):
            raise SystemExit("FAIL: the job ended before it was requeued\n" +
                             (work / f"job-{job_id}.out").read_text())
        before = kept(checkpoint)
        print(f"requeueing job {job_id} with {before} of 10 cases kept")
        print(cluster.run(["scontrol", "requeue", job_id]), end="")
        wait_for("the job to complete", lambda: ended(cluster, job_id), 600)
        job = cluster.job(job_id)
        log = (work / f"job-{job_id}.out").read_text(errors="replace")
        print(log, end="")
        print(f"job {job_id}: {job.get('JobState')}, restarts "
              f"{job.get('Restarts')}, exit {job.get('ExitCode')}")
        if job.get("JobState") != "COMPLETED":
            raise SystemExit("FAIL: the job did not complete\n" +
                             cluster.logs())
        if job.get("Restarts") != "1" or "(restart 1)" not in log:
            raise SystemExit("FAIL: the job was not requeued once")
        if out.read_bytes() != expected:
            raise SystemExit("FAIL: the requeued job's validate.json differs "
                             "from an uninterrupted run's")
        if checkpoint.exists():
            raise SystemExit("FAIL: the checkpoint outlived the output")
        print(f"PASS: requeued with {before} of 10 cases kept; the restarted "
              "job finished them, validate.json identical to a run alone")
    finally:
        cluster.stop()


if __name__ == "__main__":
    main()
