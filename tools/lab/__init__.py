"""The lab "Frames and transforms" as a course lab: skeletons to fill in and a grader.

`towerlink lab init` (tools.lab.skeleton) writes the student's starting point from the
templates (tools/lab/templates); `towerlink lab check` (tools.lab.checker) judges a folder:
checkpoint 0 on fly.launch alone (tools.lab.cp0), checkpoints 1-3 on flights of the student's
nodes in lockstep (tools.lab.flights, tools.lab.evidence, tools.lab.cp1, tools.lab.cp_follow),
with hints that name the file and line (tools.lab.hints, tools.lab.source_scan), a report
(tools.lab.report) and a class graded in parallel (tools.lab.grading).
"""
