"""LaMPilot-Bench in closed loop in SUMO (docs/lampilot.md): read a task directory (:mod:`.dataset`), build each
case's scene (:mod:`.scenes`), judge it by LaMPilot's criteria (:mod:`.criteria`), run it as a batch job
(:mod:`.runner`), and write ``cases.csv`` and the table (:mod:`.report`). ``agentic-mpc lampilot`` is the command."""
