"""The knowledge base: short documents (Markdown or text, each naming its sources) split into passages and
ranked by SQLite's FTS5 full-text index with BM25.

A document is a file with a front matter block::

    ---
    title: Japan - traffic rules for this car
    jurisdiction: JP            # or any
    sources:
      - Road Traffic Act, Article 40; https://...
    ---
    # heading
    ## a section: one passage per ## section

The shipped documents are in ``agentic_mpc/knowledge/documents/`` (traffic rules of Japan, Germany, the UK and
California, and the car's manual); users add folders of their own (``.md`` or ``.txt``). A missing, empty or
unreadable folder and a document without a title or a source are :class:`KnowledgeError` naming the file.
"""

from __future__ import annotations

import re
import sqlite3
from dataclasses import dataclass
from pathlib import Path

import yaml

SHIPPED = Path(__file__).resolve().parent / "documents"
SUFFIXES = (".md", ".txt")
_WORD = re.compile(r"[A-Za-z0-9\u00C0-\u024F]+")


class KnowledgeError(ValueError):
    """A knowledge folder or document that cannot be used; the message names it."""


@dataclass(frozen=True)
class Document:
    doc_id: str
    """The file's stem, unique across the folders (``jp-traffic-rules``)."""
    title: str
    jurisdiction: str
    sources: tuple[str, ...]
    text: str
    path: Path

    @property
    def uri(self) -> str:
        return f"knowledge://{self.doc_id}"


@dataclass(frozen=True)
class Passage:
    doc_id: str
    title: str
    section: str
    text: str
    sources: tuple[str, ...]
    score: float
    """BM25 (smaller is better, as SQLite reports it)."""

    def citation(self) -> str:
        return f"{self.title}, \"{self.section}\" ({self.doc_id}; {self.sources[0]})"


def read_document(path: Path) -> Document:
    """One document; :class:`KnowledgeError` naming the file if it has no front matter, title or source."""
    try:
        raw = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise KnowledgeError(f"{path}: cannot be read: {error}") from None
    match = re.match(r"\A---\n(.*?)\n---\n(.*)\Z", raw, re.S)
    if match is None:
        raise KnowledgeError(f"{path}: no front matter (a '---' block with title and sources) at the top")
    try:
        meta = yaml.safe_load(match.group(1)) or {}
    except yaml.YAMLError as error:
        raise KnowledgeError(f"{path}: the front matter is not YAML: {error}") from None
    title, sources = meta.get("title"), meta.get("sources")
    if not isinstance(title, str) or not title.strip():
        raise KnowledgeError(f"{path}: front matter 'title' is missing")
    if isinstance(sources, str):
        sources = [sources]
    if not isinstance(sources, list) or not sources or not all(isinstance(s, str) and s.strip() for s in sources):
        raise KnowledgeError(f"{path}: front matter 'sources' is missing: every document names where its facts are from")
    return Document(path.stem, title.strip(), str(meta.get("jurisdiction", "any")), tuple(sources),
                    match.group(2).strip(), path)


def read_folder(folder: Path) -> list[Document]:
    folder = Path(folder)
    if not folder.is_dir():
        raise KnowledgeError(f"knowledge folder {folder}: not a directory")
    files = sorted(p for p in folder.iterdir() if p.suffix in SUFFIXES and p.is_file())
    if not files:
        raise KnowledgeError(f"knowledge folder {folder}: no documents (*.md, *.txt)")
    return [read_document(path) for path in files]


def passages_of(document: Document) -> list[tuple[str, str]]:
    """(section, text) for each ``##`` section; a document without sections is one passage."""
    parts = re.split(r"^## +(.+)$", document.text, flags=re.M)
    if len(parts) == 1:
        return [(document.title, parts[0].strip())]
    return [(parts[i].strip(), parts[i + 1].strip()) for i in range(1, len(parts) - 1, 2)]


class KnowledgeBase:
    """The documents of the shipped folder (unless ``shipped=False``) and of ``folders``, indexed in memory."""

    def __init__(self, folders: tuple[Path, ...] = (), shipped: bool = True) -> None:
        documents: dict[str, Document] = {}
        for folder in ((SHIPPED,) if shipped else ()) + tuple(Path(f) for f in folders):
            for document in read_folder(folder):
                if document.doc_id in documents:
                    raise KnowledgeError(f"{document.path}: a document named {document.doc_id!r} is already in "
                                         f"{documents[document.doc_id].path.parent}")
                documents[document.doc_id] = document
        if not documents:
            raise KnowledgeError("no knowledge folder given and the shipped documents left out")
        self.documents = documents
        self._db = sqlite3.connect(":memory:", check_same_thread=False)
        self._db.execute("CREATE VIRTUAL TABLE passages USING fts5(doc_id UNINDEXED, title, section, body, "
                         "tokenize='porter unicode61')")
        for document in documents.values():
            for section, text in passages_of(document):
                self._db.execute("INSERT INTO passages VALUES (?, ?, ?, ?)",
                                 (document.doc_id, document.title, section, text))

    def search(self, query: str, k: int = 3, jurisdiction: str | None = None) -> list[Passage]:
        """The ``k`` best passages for ``query`` (any words: each is matched, ranked by BM25); with a
        ``jurisdiction`` only its documents and those for any place."""
        words = [w.lower() for w in _WORD.findall(query)]
        if not words:
            return []
        expression = " OR ".join(f'"{w}"' for w in dict.fromkeys(words))
        rows = self._db.execute(
            "SELECT doc_id, title, section, body, bm25(passages, 0.0, 2.0, 4.0, 1.0) AS score FROM passages "
            "WHERE passages MATCH ? ORDER BY score", (expression,)).fetchall()
        wanted = None if jurisdiction is None else {jurisdiction.upper(), "ANY"}
        found = [Passage(doc_id, title, section, body, self.documents[doc_id].sources, score)
                 for doc_id, title, section, body, score in rows
                 if wanted is None or self.documents[doc_id].jurisdiction.upper() in wanted]
        return found[:int(k)]
