"""Messages the workers post to the app (thread-safe: ``post_message``)."""

from __future__ import annotations

from textual.message import Message

__all__ = ["CompareProgress"]


class CompareProgress(Message):
    """A comparison finished one more method; a newer one replaces an older one in the queue."""

    def __init__(self, done: int, total: int, method: str) -> None:
        super().__init__()
        self.done = done
        self.total = total
        self.method = method

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, CompareProgress)
