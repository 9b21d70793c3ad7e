"""``agentic-mpc eval-agent``: the agent evaluation suite (``suite.yaml``), its loader (:mod:`.suite`), the
runner that puts each case to a fresh agent over its world (:mod:`.runner`), the scoring rules
(:mod:`.scoring`), the report (:mod:`.report`) and the paper's scenarios run closed-loop with a backend
(:mod:`.closed_loop`). See docs/llm-backends.md."""
