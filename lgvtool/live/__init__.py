"""Live view: the channels of a log served as they are written, over the Foxglove WebSocket
protocol, with an online estimate computed from the incoming data.

- :mod:`lgvtool.live.live_server`: the server (Foxglove's own ``foxglove-sdk``), one channel per log
  topic with the log's schema and JSON encoding;
- :mod:`lgvtool.live.front`: the front on the user's address, serving clients that offer either
  subprotocol name (``foxglove.sdk.v1``, ``foxglove.websocket.v1``) and relaying them to the SDK;
- :mod:`lgvtool.live.tap`: a log writer that also publishes every message it writes;
- :mod:`lgvtool.live.online`: estimators fed message by message;
- :mod:`lgvtool.live.live_playback`: a log played to the server at N x speed.
"""
