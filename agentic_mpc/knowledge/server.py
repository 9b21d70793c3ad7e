"""The knowledge MCP server: the documents as resources and ``search_knowledge(query, k)``, ranked passages
with their citations. Read-only: it can never change the car's specification.

``agentic-mpc knowledge-server`` serves it over stdio or HTTP (``commands/knowledge_server.py``); the agent
connects to it as to any MCP server (``knowledge://`` resources, the ``search_knowledge`` tool).
"""

# No `from __future__ import annotations`: the SDK reads the tool's annotations at runtime.
import json
from typing import Annotated

from mcp.server.mcpserver import MCPServer
from mcp_types import ToolAnnotations
from pydantic import Field

from agentic_mpc.knowledge.store import KnowledgeBase

SEARCH_TOOL = "search_knowledge"
INDEX_URI = "knowledge://index"
MAX_PASSAGE_CHARS = 900
"""A passage is cut here in a search answer (the whole document is its resource)."""


def build_knowledge_server(base: KnowledgeBase, name: str = "agentic-mpc-knowledge") -> MCPServer:
    server = MCPServer(name, instructions=(
        "Traffic rules by jurisdiction (which side traffic keeps to, making way for emergency vehicles, speed "
        "limits, following distance, overtaking, the hard shoulder) and the car's manual. Search with "
        f"{SEARCH_TOOL}; read a whole document at its knowledge:// URI; {INDEX_URI} lists them. Cite the "
        "document an answer uses."), log_level="WARNING")

    @server.tool(name=SEARCH_TOOL, description=(
        "Search the knowledge base (traffic rules of Japan, Germany, the UK and California, the car's manual, and "
        "any documents the user added) and return the k best passages, each with its document, section and "
        "sources to cite."), annotations=ToolAnnotations(readOnlyHint=True, destructiveHint=False),
        structured_output=False)
    def search_knowledge(query: Annotated[str, Field(min_length=1, max_length=500, description="what to look up")],
                         k: Annotated[int, Field(ge=1, le=10, description="how many passages")] = 3,
                         jurisdiction: Annotated[str | None, Field(
                             pattern=r"^[A-Za-z]{2}(-[A-Za-z0-9]{1,3})?$",
                             description="only this place's documents (JP, DE, UK, US-CA) and general ones")] = None,
                         ) -> str:
        found = base.search(query, k, jurisdiction)
        return json.dumps({"query": query, "passages": [
            {"document": p.doc_id, "uri": f"knowledge://{p.doc_id}", "title": p.title, "section": p.section,
             "text": p.text[:MAX_PASSAGE_CHARS], "sources": list(p.sources), "cite": p.citation(),
             "rank": rank + 1} for rank, p in enumerate(found)]}, ensure_ascii=False)

    @server.resource(INDEX_URI, name="index", description="Every document: id, title, jurisdiction, sources.",
                     mime_type="application/json")
    def index() -> str:
        return json.dumps({"documents": [
            {"id": d.doc_id, "uri": d.uri, "title": d.title, "jurisdiction": d.jurisdiction, "sources": list(d.sources)}
            for d in base.documents.values()]}, ensure_ascii=False)

    for document in base.documents.values():
        server.resource(document.uri, name=document.doc_id, description=document.title,
                        mime_type="text/markdown")(_reader(document.text))
    return server


def _reader(text: str):
    def read() -> str:
        return text

    return read
