"""TransformListener (tf2_ros): fills a Buffer from the system's transform stream.

``TransformListener(buffer, node)`` subscribes to TOWERLINK_TRANSFORM on the node's
link; the node's background thread (tf2_ros's listener thread) feeds each one into
the buffer through :class:`~common.tf2_ros.stream.TransformStream`. ``node`` may be a
connection string, for which the listener makes a node of its own (closed by
:meth:`close`). Callbacks added with :meth:`add_callback` run after each transform
goes in (the MessageFilter re-checks its queue there).
"""
from __future__ import annotations

from collections.abc import Callable

from common.frames import Buffer

from .node import Node
from .stream import TransformStream


class TransformListener:
    def __init__(self, buffer: Buffer, node: "Node | str", *, name: str = "tf_listener") -> None:
        self._own = isinstance(node, str)
        self.node = Node(name, node) if self._own else node
        self.buffer = buffer
        self.stream = TransformStream(buffer)
        self._callbacks: list[Callable[[], None]] = []
        self.node.subscribe("TOWERLINK_TRANSFORM", self._on_transform)

    def add_callback(self, fn: Callable[[], None]) -> None:
        """`fn()` runs in the listener's thread after each transform is stored."""
        self._callbacks.append(fn)

    @property
    def received(self) -> int:
        return self.stream.received

    def _on_transform(self, msg) -> None:
        if self.stream.feed(msg):
            for fn in self._callbacks:
                fn()

    def close(self) -> None:
        if self._own:
            self.node.close()
