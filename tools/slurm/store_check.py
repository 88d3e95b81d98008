#!/usr/bin/env python3
"""Checks on demcal results stores for tools/slurm/test-cluster.sh (standard library only).

  store_check.py count DB                 runs stored
  store_check.py tasks DB STATE           Slurm tasks in STATE (open, stored, cancelled, ...)
  store_check.py jobs DB STATE            their array job ids, joined by commas
  store_check.py ledger DB                runs, arrays and tasks; fails if a run went out twice
  store_check.py forget-job-ids DB        as if the coordinator died between writing its open tasks
                                          and recording sbatch's answer (the one write made here)
  store_check.py arrays DB                job arrays submitted
  store_check.py done DB                  fails unless every run is done
  store_check.py equal DB_A DB_B          fails unless both hold the same runs with the same results
                                          (outcomes compared whole, but for their wall times)
  store_check.py timelimit DB PARAM MIN   fails unless the runs with PARAM >= MIN failed at
                                          Slurm's time limit and every other run is done
"""
import json
import sqlite3
import sys


def rows(db, sql, args=()):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=30)
    try:
        return con.execute(sql, args).fetchall()
    finally:
        con.close()


def timeless(v):
    """An outcome without its wall times, which differ from run to run."""
    if isinstance(v, dict):
        return {k: timeless(x) for k, x in v.items() if k != "wall_s"}
    if isinstance(v, list):
        return [timeless(x) for x in v]
    return v


def fail(msg):
    print(f"store_check: {msg}", file=sys.stderr)
    sys.exit(1)


def main(argv):
    what, db = argv[1], argv[2]
    if what == "count":
        print(rows(db, "SELECT COUNT(*) FROM runs")[0][0])
    elif what == "tasks":
        print(rows(db, "SELECT COUNT(*) FROM cluster_tasks WHERE state = ?", (argv[3],))[0][0])
    elif what == "jobs":
        ids = rows(db, "SELECT DISTINCT job_id FROM cluster_tasks WHERE state = ? AND job_id IS NOT NULL", (argv[3],))
        print(",".join(i[0] for i in ids))
    elif what == "ledger":
        runs = rows(db, "SELECT COUNT(*) FROM runs")[0][0]
        arrays = rows(db, "SELECT COUNT(DISTINCT job_id) FROM cluster_tasks")[0][0]
        tasks = rows(db, "SELECT COUNT(*) FROM cluster_tasks")[0][0]
        twice = rows(db, "SELECT stage, idx, COUNT(*) FROM cluster_tasks GROUP BY stage, idx HAVING COUNT(*) > 1")
        if twice:
            fail(f"{db}: runs submitted more than once (stage, run, tasks): {twice}")
        if tasks != runs:
            fail(f"{db}: {tasks} tasks submitted for {runs} stored runs")
        not_slurm = rows(db, "SELECT COUNT(*) FROM runs WHERE executor NOT LIKE 'slurm job %'")[0][0]
        if not_slurm:
            fail(f"{db}: {not_slurm} runs were not made by Slurm tasks")
        print(f"{runs} {arrays} {tasks}")
    elif what == "forget-job-ids":
        con = sqlite3.connect(db, timeout=30)
        with con:
            n = con.execute("UPDATE cluster_tasks SET job_id = NULL WHERE state = 'open'").rowcount
        con.close()
        print(n)
    elif what == "arrays":
        print(rows(db, "SELECT COUNT(DISTINCT job_id) FROM cluster_tasks")[0][0])
    elif what == "done":
        bad = rows(db, "SELECT idx, status, error FROM runs WHERE status != 'done'")
        if bad:
            fail(f"{db}: runs not done: {bad}")
        print(rows(db, "SELECT COUNT(*) FROM runs")[0][0])
    elif what == "equal":
        q = "SELECT stage, idx, status, response, outputs, error_kind, fingerprint, seed FROM runs ORDER BY stage, idx"
        a, b = rows(db, q), rows(argv[3], q)
        if len(a) != len(b):
            fail(f"{db} has {len(a)} runs, {argv[3]} has {len(b)}")
        for x, y in zip(a, b):
            x = list(x)
            y = list(y)
            x[4], y[4] = timeless(json.loads(x[4])), timeless(json.loads(y[4]))
            if x != y:
                fail(f"stage {x[0] + 1} run {x[1] + 1} differs:\n  {x}\n  {y}")
        print(len(a))
    elif what == "timelimit":
        param, least = argv[3], float(argv[4])
        long_runs = 0
        for inputs, status, kind, error in rows(db, "SELECT inputs, status, error_kind, error FROM runs"):
            if json.loads(inputs)[param] >= least:
                long_runs += 1
                if status != "failed" or kind != "time_limit" or "time limit" not in (error or ""):
                    fail(f"a run with {param} >= {least} is {status} ({kind}): {error}")
            elif status != "done":
                fail(f"a short run is {status}: {error}")
        if long_runs == 0:
            fail(f"no run has {param} >= {least}")
        print(long_runs)
    else:
        fail(f"unknown check {what}")


if __name__ == "__main__":
    main(sys.argv)
