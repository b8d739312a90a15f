#!/usr/bin/python3
"""A run of modal-precompute that cannot finish must not damage the results already in its output
folder. On the small scene, after one good run:

* output folder not writable (a path under a regular file; a read-only bind mount of the folder),
* disk full while writing (RLIMIT_FSIZE: every file larger than the limit fails to grow, EFBIG),
  at limits that stop it in a VTU file and in the .h5,
* SIGKILL while it writes its outputs (as soon as the temporary file of each main output appears),

the earlier .h5, .mrt, report.json, used_parameters.prm and .pvd files must be byte-identical
afterwards, any other earlier file (the VTU mode shapes, written while the modes are computed) may
only have been replaced by a complete one, and no new file may appear under a final name. A run that
fails (not killed) must exit non-zero with a message naming the cause and leave no temporary file."""
import json
import os
import resource
import shutil
import signal
import struct
import subprocess
import sys
import time

from precompute_run import binary_and_fresh_workdir, vtu_compression_ratio

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = "small_block"
# Written once, at the end of the run, from staged temporaries: they must never change.
COMMITTED_TOGETHER = (f"{SCENE}.h5", f"{SCENE}.mrt", "report.json", "used_parameters.prm")


def wait_until_stopped(pid):
    """SIGSTOP is delivered asynchronously: wait (at most a second) until the process is stopped."""
    deadline = time.monotonic() + 1.0
    while time.monotonic() < deadline:
        with open(f"/proc/{pid}/stat") as f:
            if f.read().rsplit(")", 1)[1].split()[0] in ("T", "t"):
                return
        time.sleep(1e-5)


def is_temporary(name):
    return ".tmp." in name


def snapshot(folder):
    """{name: bytes} of every file under a final name."""
    return {n: open(os.path.join(folder, n), "rb").read() for n in sorted(os.listdir(folder)) if not is_temporary(n)}


def complete(name, data):
    """Whether a file is whole, as far as its format tells without a library."""
    if name.endswith(".vtu") or name.endswith(".pvd"):
        return data.rstrip().endswith(b"</VTKFile>")
    if name.endswith(".mrt"):  # the header's file size (docs/basis-format.md)
        return len(data) >= 64 and struct.unpack_from("<Q", data, 24)[0] == len(data)
    if name.endswith(".json"):
        try:
            json.loads(data)
            return True
        except ValueError:
            return False
    if name.endswith(".h5"):  # renamed only once HDF5 has opened it again; the signature at least
        return data.startswith(b"\x89HDF\r\n\x1a\n")
    return True  # used_parameters.prm; meshes and their keys are the mesher's cache, written atomically


def damage(before, folder, allow_temporaries):
    """What the failed run did to the folder that it must not have done."""
    after = snapshot(folder)
    problems = [f"new file {n}" for n in after if n not in before]
    for name, data in before.items():
        if name not in after:
            problems.append(f"{name} removed")
        elif after[name] != data and (name in COMMITTED_TOGETHER or name.endswith(".pvd")):
            problems.append(f"{name} changed")
        elif after[name] != data and not complete(name, after[name]):
            problems.append(f"{name} replaced by an incomplete file")
    leftovers = [n for n in os.listdir(folder) if is_temporary(n)]
    if leftovers and not allow_temporaries:
        problems.append("temporary files left: " + ", ".join(leftovers))
    for n in leftovers:  # a killed run cannot clean up; the next case starts clean
        os.remove(os.path.join(folder, n))
    return problems


def failed_cleanly(run, words):
    problems = [] if run.returncode > 0 else [f"exit status {run.returncode}"]
    message = run.stdout + run.stderr
    problems += [f"message lacks '{w}'" for w in words if w not in message]
    return problems


def file_size_limit(limit):
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def main():
    args = binary_and_fresh_workdir()
    for name in ("small_scene.prm", "block.geo"):
        shutil.copy(os.path.join(HERE, name), args.workdir)
    prm = os.path.join(args.workdir, "small_scene.prm")
    results = os.path.join(args.workdir, "results")

    def command(output):
        return [args.binary, prm, "--output-dir", output, "--quiet"]

    subprocess.run(command(results), check=True, capture_output=True)
    before = snapshot(results)
    outcomes = []  # (case, problems or None when skipped, note)

    # --- not writable --------------------------------------------------------------------------
    blocker = os.path.join(args.workdir, "a_regular_file")
    open(blocker, "w").close()
    run = subprocess.run(command(os.path.join(blocker, "results")), capture_output=True, text=True)
    outcomes.append(("output folder under a regular file", failed_cleanly(run, ["a_regular_file"]), ""))

    # Root writes through chmod, so the folder itself is made read-only by a bind mount in a private
    # mount namespace; a probe write first proves that the mount is possible and read-only here.
    read_only = ["unshare", "--mount", "sh", "-c",
                 'mount --bind "$0" "$0" && mount -o remount,bind,ro "$0" && ! touch "$0/probe" 2>/dev/null && exec "$@"',
                 results]
    probe = subprocess.run(read_only + ["true"], capture_output=True, text=True)
    if probe.returncode != 0:
        outcomes.append(("read-only output folder (bind mount)", None,
                         "skipped: no read-only bind mount here: " + probe.stderr.strip()[:80]))
    else:
        run = subprocess.run(read_only + command(results), capture_output=True, text=True)
        outcomes.append(("read-only output folder (bind mount)",
                         failed_cleanly(run, ["Read-only file system"]) + damage(before, results, False), ""))

    # --- disk full -----------------------------------------------------------------------------
    # A file size limit stops the first output that outgrows it. The VTU files come first: half the
    # smallest stops the run in one of them. Without mode shapes and compressed ('VTU compression =
    # fast', deal.II's writer, whose compression is checked too), the VTU files (validation fields) are
    # smaller than the .h5, written next: a limit between them stops the run in the .h5. (The .mrt and report.json are
    # smaller than the .h5 and written after it: no limit stops them first.)
    no_vtu = os.path.join(args.workdir, "no_vtu.prm")
    with open(no_vtu, "w") as f:
        f.write(open(prm).read() + "\nsubsection Output\n  set VTU modes = 0\n  set VTU compression = fast\nend\n")
    # On the meshes of 'results', which the runs below reuse: gmsh's HXT does not mesh alike twice,
    # and on fresh meshes the sizes moved enough to stop the .h5 case in a VTU (2 of 6 runs).
    scratch = os.path.join(args.workdir, "no_vtu_sizes")
    os.makedirs(scratch, exist_ok=True)
    for name in os.listdir(results):
        if name.endswith((".msh", ".key")):
            shutil.copy(os.path.join(results, name), scratch)
    subprocess.run([args.binary, no_vtu, "--output-dir", scratch, "--quiet"], check=True, capture_output=True)
    largest_vtu = max(os.path.getsize(os.path.join(scratch, n)) for n in os.listdir(scratch) if n.endswith(".vtu"))
    ratios = [vtu_compression_ratio(os.path.join(scratch, n)) for n in os.listdir(scratch) if n.startswith("modes_")
              and n.endswith(".vtu")]
    outcomes.append(("'VTU compression = fast' compresses the mode-shape VTU files",
                     [f"zlib streams {max(ratios):.3f} of the raw data"] if max(ratios) > 0.9 else [], ""))
    h5_size = os.path.getsize(os.path.join(scratch, f"{SCENE}.h5"))
    if largest_vtu >= h5_size:
        outcomes.append(("disk full in the .h5", [f"cannot be targeted: a VTU ({largest_vtu} B) >= the .h5 ({h5_size} B)"], ""))
    # Open MPI's start-up (PMIx's shared-memory store, the shared-memory transport) writes files larger
    # than these limits and MPI_Init fails before the program runs: one process needs neither.
    mpi_without_shared_files = dict(os.environ, PMIX_MCA_gds="hash", OMPI_MCA_btl="self")
    vtu_limit = min(len(d) for n, d in before.items() if n.endswith(".vtu")) // 2
    for scene_file, limit, stopped_in in ((prm, vtu_limit, ".vtu"),
                                          (no_vtu, (largest_vtu + h5_size) // 2, f"{SCENE}.h5")):
        run = subprocess.run([args.binary, scene_file, "--output-dir", results, "--quiet"], capture_output=True,
                             text=True, preexec_fn=file_size_limit(limit), env=mpi_without_shared_files)
        outcomes.append((f"disk full in a {stopped_in} (files limited to {limit} B)",
                         failed_cleanly(run, ["disk full", stopped_in]) + damage(before, results, False), ""))

    # --- killed ----------------------------------------------------------------------------------
    # As soon as the target's temporary file is seen (polled every 0.1 ms) the run is stopped
    # (SIGSTOP), where it is is read from the folder, then it is killed. Until its results are
    # committed (renamed, .h5 first) nothing earlier may change; a kill that lands during the renames
    # (about a millisecond) may leave a mixed set, but only of complete files.
    for target in (f"{SCENE}.h5", f"{SCENE}.mrt", "report.json"):
        started = time.monotonic()
        child = subprocess.Popen(command(results), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        hit = None
        while child.poll() is None and hit is None and time.monotonic() - started < 60:
            hit = next((n for n in os.listdir(results) if is_temporary(n) and n.startswith(target)), None)
            time.sleep(1e-4)  # fine enough for the windows of a few ms, and leaves the CPU to the run
        if hit:
            child.send_signal(signal.SIGSTOP)
            wait_until_stopped(child.pid)  # else the run may rename files after the check below
            committing = not os.path.exists(os.path.join(results, f"{SCENE}.h5.tmp.{child.pid}"))
        child.kill()
        child.wait()
        if not hit:
            before = snapshot(results)  # the run finished: its results are the earlier ones now
            outcomes.append((f"SIGKILL on {target}", None, "window missed (the run finished first)"))
        elif committing:
            problems = [f"{n} incomplete" for n, d in snapshot(results).items() if not complete(n, d)]
            damage(before, results, True)  # only to clear the temporaries
            before = snapshot(results)
            outcomes.append((f"SIGKILL when {hit} appeared, landed in the commit", problems, ""))
        else:
            outcomes.append((f"SIGKILL when {hit} appeared", damage(before, results, True), ""))

    failures = 0
    for case, problems, note in outcomes:
        status = note if problems is None else ("ok" if not problems else "FAILED: " + "; ".join(problems))
        print(f"{case:60s} {status}")
        failures += bool(problems)
    kills = sum(1 for case, problems, note in outcomes if case.startswith("SIGKILL when"))
    if kills == 0:
        print("FAILED: no kill landed while the outputs were being written")
        failures += 1
    print(f"{len(outcomes) - failures} passed, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
