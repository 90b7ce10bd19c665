"""The coalition agents' message transport, pure part (no ROS): how agents' logical messages
travel over a lossy, reordering channel and how coalitions are committed to.

The paper assumes every robot reaches every other (Sec. IV-H) and models the delay and loss of
Fig. 9 (Sec. V-B-4); the rest is ours, each module documenting its choices:

=====================  =========================================================================
codec                  the channel's logical messages (:class:`~.codec.ChannelMessage`, kinds
                       REQUEST ... INFORMATION) and their validation (:class:`~.codec.ChannelCodec`)
batching               one batch per recipient per step, piggybacked ACKs, the inbox order
batch_columns          a batch as columns (the wire form of AgentMessageBatch) and their validation
link_model             Sec. V-B-4 / Fig. 9: delay N(3.85 ms, 5.05 ms) truncated at 0, loss
retry                  when an unanswered copy is re-sent (fast retransmit, tail timeout, RTT)
commitments            request-and-wait: one commitment per robot, a leader's negotiation
reliable_channel       one robot's end: numbering, retries, duplicates, commitments
information_stream     streamed INFORMATION values (latest wins, stale after a timeout)
=====================  =========================================================================

The ROS side (publishers, subscriptions, QoS, message conversion) is
:mod:`coalition_agents.transport.agent_channel` (one robot's end), :mod:`~coalition_agents.transport.channel_hub`
(a process's shared endpoints) and :mod:`~coalition_agents.transport.batch_wire` (conversions).
"""
