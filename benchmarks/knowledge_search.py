"""Search quality of the knowledge base on questions written apart from its documents: the right document in
the top 3, searched as the rules backend searches (among the documents of the place the question names, else
all: no road here) and as a model would with the raw question.

    python benchmarks/knowledge_search.py benchmarks/knowledge_unseen_questions.yaml

The questions file: a YAML list of ``{question: ..., document: <id>}``. Prints each miss and the rates;
writes nothing.
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml

from agentic_mpc.agent.backends.rules_knowledge import question_call
from agentic_mpc.knowledge.store import KnowledgeBase


def main(path: str) -> None:
    cases = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    base = KnowledgeBase()
    hits = {"as the rules search (place filter)": 0, "the raw question": 0}
    for case in cases:
        question, wanted = case["question"], case["document"]
        arguments = question_call(question)[1]
        filtered = [p.doc_id for p in base.search(arguments["query"], 3, arguments.get("jurisdiction"))]
        raw = [p.doc_id for p in base.search(question, 3)]
        for name, top in zip(hits, (filtered, raw), strict=True):
            if wanted in top:
                hits[name] += 1
            else:
                print(f"miss ({name}): {question!r} wanted {wanted}, got {top}")
    for name, count in hits.items():
        print(f"{name}: the right document in the top 3 for {count} of {len(cases)} ({100 * count / len(cases):.0f} %)")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python benchmarks/knowledge_search.py QUESTIONS.yaml")
    main(sys.argv[1])
