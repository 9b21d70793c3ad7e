"""The knowledge base (traffic rules by jurisdiction, the car's manual, the user's documents) and its MCP
server: :mod:`.store` (documents, passages, FTS5/BM25 search), :mod:`.server` (``search_knowledge`` and the
``knowledge://`` resources). ``agentic-mpc knowledge-server`` serves it; docs/knowledge.md."""
