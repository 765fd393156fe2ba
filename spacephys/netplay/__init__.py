"""Two players on two machines: a rollback session over UDP (session.py), the inputs it
carries (inputs.py), its packets and channel with a test hook for latency, jitter and loss
(link.py). docs/netplay.md shows a game using it."""
from .inputs import Inputs
from .link import Channel, Conditions, Packet
from .session import Session

__all__ = ["Session", "Inputs", "Channel", "Conditions", "Packet"]
