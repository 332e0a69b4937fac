"""MURDOCH task allocation: subject-set publish/subscribe, auctions, and consensus allocators.

See docs/murdoch.md. Entry points: `murdoch.node.Node` (an agent on the bus),
`murdoch.multicast.MulticastTransport` and `murdoch.memory_bus.MemoryBus` (transports),
`murdoch.auction` (the sans-IO auctioneer and bidder).
"""

__version__ = "0.1.0"
