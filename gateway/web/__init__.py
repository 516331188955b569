"""The live view: one web page (a local map, the links, a timeline of drops) fed from the bus.

address.py parses ``[ADDR:]PORT``; model.py (sans-IO) folds bus messages into what the page
shows; server.py serves the page and streams it (aiohttp, server-sent events), fed in-process
by the daemon (``cornet run --web``) or from a ZeroMQ bus (``cornet web --zmq``); static/ is the
page itself (plain JavaScript on a canvas). docs/web.md describes it.
"""
