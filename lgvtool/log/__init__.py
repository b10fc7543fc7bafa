"""The MCAP log contract: topics, schemas, writer, reader and salvage (docs/log-format.md)."""

from lgvtool.log import topics
from lgvtool.log.reader import LogMessage, LogReader, LogWarning, RawMessage, TopicInfo
from lgvtool.log.writer import FORMAT_VERSION, LogWriter

Message = LogMessage

__all__ = [
    "FORMAT_VERSION",
    "LogMessage",
    "LogReader",
    "LogWarning",
    "LogWriter",
    "Message",
    "RawMessage",
    "TopicInfo",
    "topics",
]
