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
import re
import pathlib
import shutil
import socket
import subprocess
import sys
import tempfile
import time

CASES = ["--cases", "20", "--effects", "none,rig_compliance", "--seed", "3"]
ENDED = ("COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL",
         "PREEMPTED", "OUT_OF_MEMORY", "BOOT_FAIL", "DEADLINE")


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
        self.work = work  # short: Unix socket paths end at 108 bytes
        self.daemons = []
        self.jobs = []
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
        wait_for("an idle node", lambda: self.run(
            ["sinfo", "-h", "-o", "%t"]).split() == ["idle"], 60)

    def spawn(self, command):
        self.daemons.append(subprocess.Popen(
            command, env=self.env, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, start_new_session=True))

    def run(self, command):
        try:
            done = subprocess.run(command, env=self.env, capture_output=True,
                                  text=True, timeout=60)
        except subprocess.TimeoutExpired:
            return f"{command[0]}: no answer within 60 s"
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
        # The jobs first: their steps and ranks would outlive slurmd.
        for job_id in self.jobs:
            self.run(["scancel", job_id])
        for job_id in self.jobs:
            try:
                wait_for("the job to end", lambda: ended(self, job_id), 60)
            except SystemExit:
                pass
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
    return cluster.job(job_id).get("JobState") in ENDED


def kept(folder):
    if not folder.is_dir():
        return 0
    return sum(1 for p in folder.iterdir()
               if re.fullmatch(r"item-\d+\.json", p.name))


def end_job_when_kept(cluster, job_id, checkpoint, cases, how):
    """Ends the job `how` once the checkpoint keeps `cases` cases."""
    wait_for(f"{cases} cases kept",
             lambda: kept(checkpoint) >= cases or ended(cluster, job_id), 300)
    if ended(cluster, job_id):
        raise SystemExit(f"FAIL: the job ended before {how}: "
                         f"{cluster.job(job_id)}\n" + cluster.logs())
    print(f"{how} with {kept(checkpoint)} of 20 cases kept")
    restarts = int(cluster.job(job_id).get("Restarts", "0"))
    if how == "time limit":  # what --signal=B:USR1@120 sends
        command = ["scancel", "--batch", "--signal=USR1", job_id]
    else:
        command = ["scontrol", "requeue", job_id]
    print(cluster.run(command), end="")
    # The job runs again when its script says so (its state passes through
    # COMPLETED while Slurm requeues it).
    log = checkpoint.parent / f"job-{job_id}.out"
    wait_for("the restart", lambda: f"(restart {restarts + 1})" in
             log.read_text(errors="replace"), 300)


def main():
    kcrig = str(pathlib.Path(sys.argv[1]).resolve())
    source, work = pathlib.Path(sys.argv[2]), pathlib.Path(sys.argv[3])
    if os.geteuid() != 0:
        raise SystemExit("FAIL: the test runs Slurm's daemons as root; "
                         "run it as root (as CI does)")
    for tool in ("slurmctld", "slurmd", "sbatch", "munged", "mungekey"):
        if shutil.which(tool) is None:
            raise SystemExit(f"FAIL: {tool} not installed (scripts/setup.sh)")
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    subprocess.run([kcrig, "validate", "--quiet", *CASES, "--out",
                    str(work / "alone.json")], check=True,
                   stdout=subprocess.DEVNULL)
    expected = (work / "alone.json").read_bytes()

    cluster = Cluster(pathlib.Path(tempfile.mkdtemp(prefix="kcrig-slurm-")))
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
        cluster.jobs.append(job_id)
        end_job_when_kept(cluster, job_id, checkpoint, 4, "time limit")
        end_job_when_kept(cluster, job_id, checkpoint, 10, "preemption")
        wait_for("the job to complete", lambda: ended(cluster, job_id), 600)
        job = cluster.job(job_id)
        log = (work / f"job-{job_id}.out").read_text(errors="replace")
        print(log, end="")
        print(f"job {job_id}: {job.get('JobState')}, restarts "
              f"{job.get('Restarts')}, exit {job.get('ExitCode')}")
        if job.get("JobState") != "COMPLETED":
            raise SystemExit("FAIL: the job did not complete\n" +
                             cluster.logs())
        if (job.get("Restarts") != "2" or "(restart 2)" not in log or
                "near the time limit: requeued" not in log):
            raise SystemExit("FAIL: the job was not requeued twice")
        if out.read_bytes() != expected:
            raise SystemExit("FAIL: the requeued job's validate.json differs "
                             "from an uninterrupted run's")
        if checkpoint.exists():
            raise SystemExit("FAIL: the checkpoint outlived the output")
        print("PASS: ended by its time limit and by a requeue, the job "
              "finished its cases; validate.json identical to a run alone")
    finally:
        cluster.stop()
        shutil.rmtree(cluster.work, ignore_errors=True)


if __name__ == "__main__":
    main()
