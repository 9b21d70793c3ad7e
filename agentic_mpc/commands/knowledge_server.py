"""``agentic-mpc knowledge-server``: the knowledge base (traffic rules, the car's manual, your own documents)
as a read-only MCP server: ``search_knowledge(query, k)`` and one ``knowledge://`` resource per document.

    agentic-mpc knowledge-server                               # stdio, the shipped documents
    agentic-mpc knowledge-server --folder my_manuals --transport http --port 8766

Your folder holds Markdown or text files, each with a front matter block naming its title and sources (see
agentic_mpc/knowledge/store.py). Over HTTP the same Host/Origin checks and bearer token as ``serve`` apply
(``AGENTIC_MPC_TOKEN``; a bind that is not loopback needs one). A folder that is missing, empty or holds a
document without a source is an error naming it, exit 2, before the server starts.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("knowledge-server", help="the knowledge base as an MCP server",
                                   description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--folder", type=Path, action="append", default=[], metavar="DIR",
                        help="a folder of your own documents (repeatable)")
    parser.add_argument("--no-shipped", dest="shipped", action="store_false",
                        help="leave out the shipped documents (traffic rules, the car's manual)")
    parser.add_argument("--transport", choices=("stdio", "http"), default="stdio")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8766)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from agentic_mpc.knowledge.server import build_knowledge_server
    from agentic_mpc.knowledge.store import KnowledgeBase, KnowledgeError

    try:
        server = build_knowledge_server(KnowledgeBase(tuple(args.folder), shipped=args.shipped))
    except KnowledgeError as error:
        print(f"agentic-mpc knowledge-server: {error}", file=sys.stderr)
        return 2
    if args.transport == "stdio":
        server.run("stdio")
        return 0
    from agentic_mpc.mcp.http import TOKEN_ENV, BindError, bind_socket, check_bind, serve_http

    token = os.environ.get(TOKEN_ENV) or None
    try:
        check_bind(args.host, token)
        listening = bind_socket(args.host, args.port)
    except BindError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"knowledge MCP server at http://{args.host}:{args.port}/mcp", file=sys.stderr, flush=True)
    try:
        serve_http(server, listening, args.host, args.port, token=token)
    except KeyboardInterrupt:
        pass
    finally:
        listening.close()
    return 0
