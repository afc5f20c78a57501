"""The lab "Frames and transforms" for a class: a student's starting point, and the grader.

  towerlink lab init DIR                 the three nodes as skeletons with the lab's TODOs,
                                         fly.launch with its static_transform_publisher line,
                                         and a README that walks the lab's steps
  towerlink lab check DIR                run the student's work against the lab's world and
                                         print a report card, one line per checkpoint
  towerlink lab check DIR --checkpoint 1 one checkpoint (repeatable)
  towerlink lab check SUBMISSIONS/*      a class: one row per student, checked in parallel

The checkpoints: 0 the static transform reproduces the lab's seven self-checkpoint rows (to
0.1 m; no flight); 1 the drone reaches the tower's three goals through tower_to_map and
fly.launch's transform; 2 the rover follows the drone's ground point through the tilting drone
frame (follow error and wobble measured); 3 through the yaw-only frame the wobble is gone and
the follow error is under 1 m RMS. The flights run in lockstep at full speed (the figures do
not depend on the machine); each failing checkpoint says what went wrong and where (file and
line). The report (report.md, report.json, tracks.png and the flights' run folders) goes to
DIR/lab-check, or for a class to OUT/<student> (--out, default ./lab-check) with class.md.

With Ray installed (pip install 'towerlink[sweep]') a class is checked as Ray tasks, else in a
pool of local processes (--jobs). Exit status 0 iff every checkpoint asked for passes for
every student.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    init = sub.add_parser("init", help="write the student's starting point into DIR")
    init.add_argument("dir", metavar="DIR")
    init.add_argument("--force", action="store_true", help="overwrite the lab's files if DIR has them")
    chk = sub.add_parser("check", help="check one student's DIR, or a class (several DIRs)",
                         formatter_class=argparse.RawDescriptionHelpFormatter)
    chk.add_argument("dirs", nargs="+", metavar="DIR")
    chk.add_argument("--checkpoint", "-c", type=int, action="append", choices=(0, 1, 2, 3), default=None,
                     metavar="N", help="check only checkpoint N (0-3; repeatable); default all four")
    chk.add_argument("--out", default=None, metavar="DIR",
                     help="report folder (one student; default DIR/lab-check) or the class's root "
                          "(default ./lab-check: a folder per student, class.md)")
    chk.add_argument("--jobs", "-j", type=int, default=None,
                     help="students checked at once without Ray (default: the CPU count)")
    ray = chk.add_mutually_exclusive_group()
    ray.add_argument("--ray", dest="ray", action="store_true", default=None, help="check a class on Ray")
    ray.add_argument("--no-ray", dest="ray", action="store_false", help="local processes even if Ray is there")
    chk.add_argument("--no-plot", action="store_true", help="no track plots (a little faster)")
    chk.add_argument("--json", action="store_true", help="print the reports as JSON instead of the cards")


def run(args: argparse.Namespace) -> int:
    if args.action == "init":
        return _init(args)
    return _check(args)


def _init(args) -> int:
    from tools.lab.skeleton import write_skeleton
    try:
        files = write_skeleton(args.dir, force=args.force)
    except FileExistsError as exc:
        print(f"towerlink lab init: {exc}", file=sys.stderr)
        return 2
    print(f"towerlink lab init: wrote {', '.join(p.name for p in files)} into {args.dir}")
    print(f"next: read {Path(args.dir) / 'README.md'}; check your work with `towerlink lab check {args.dir}`")
    return 0


def _check(args) -> int:
    from tools.lab.grading import grade
    from tools.lab.report import card, class_markdown, class_table
    folders = [Path(d) for d in args.dirs if Path(d).is_dir()]
    for d in args.dirs:
        if not Path(d).is_dir():
            print(f"towerlink lab check: {d}: not a folder, skipped", file=sys.stderr)
    if not folders:
        return 2
    asked = sorted(set(args.checkpoint or (0, 1, 2, 3)))
    many = len(folders) > 1

    def on_done(rep: dict) -> None:
        if not args.json and not many:
            print(card(rep), flush=True)
        elif not args.json:
            ok = sum(c["passed"] for c in rep["checkpoints"])
            print(f"  {rep['name']}: {ok}/{len(rep['checkpoints'])} ({rep['wall_s']:.1f} s)", flush=True)

    if many and not args.json:
        print(f"towerlink lab check: {len(folders)} students, checkpoints {', '.join(map(str, asked))}", flush=True)
    reps, how = grade(folders, asked, Path(args.out) if args.out else None, args.jobs, args.ray,
                      plot=not args.no_plot, on_done=on_done)
    if args.json:
        print(json.dumps(reps if many else reps[0], indent=2, default=str))
    elif many:
        table = class_table(reps)
        root = Path(args.out) if args.out else Path("lab-check")
        root.mkdir(parents=True, exist_ok=True)
        (root / "class.md").write_text(class_markdown(reps))
        (root / "class.json").write_text(json.dumps(reps, indent=2, default=str))
        print("\n" + table + f"\n\n({how}; reports in {root}/<student>, the table in {root}/class.md)")
    return 0 if all(r["passed"] for r in reps) else 1
