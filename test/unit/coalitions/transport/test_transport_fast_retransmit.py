"""Re-sending only what is known lost (core.transport.reliable_channel, no ROS): a busy receiver is never
re-flooded, a copy proven lost by a later copy's answer is re-sent at once, a tail loss falls back
to the backed-off timeout, a peer is given up only after peer_timeout of silence, and the
receiver's queue hands negotiation messages to the agent before queued offers."""
from __future__ import annotations

import pytest

from coalition_agents.core.transport.batching import InboxQueue, piggybacked_ack
from coalition_agents.core.transport.codec import (
    MessageKind, OfferSummary, commit_request_message, offer_message, release_message, request_message,
)
from coalition_agents.core.information import Entity
from coalition_agents.core.transport.reliable_channel import ReliableChannel
from coalition_agents.core.transport.retry import RetryPolicy
from coalition_agents.core.requests import InformationRequest

TEAM = ('robot_1', 'robot_2', 'robot_3')
TICK = 0.01


def request(library, text='F_G(X)', sender='robot_1', message_id=1):
    return request_message(InformationRequest(sender, library.parse(text, TEAM)), message_id)


def send(library, sender, now, receiver='robot_2'):
    [copy] = sender.send(request(library, message_id=sender.new_id()), now, [receiver])
    return copy


def ack(copy, now, sender):
    """``copy``'s receiver acknowledges it; the ACK reaches ``sender`` at ``now``."""
    sender.receive(piggybacked_ack(copy.receiver, sender.robot, copy.message_id), now)


def ticks(start, end):
    return [start + k * TICK for k in range(int(round((end - start) / TICK)) + 1)]


def test_a_slow_but_alive_receiver_gets_no_copy_twice(library):
    """Acks delayed 1 s (the receiver works through a backlog), no loss, default policy: a message
    every 10 ms for 3 s is answered without a single re-send (the measured round trips include
    the lag, and every answer restarts the tail timer)."""
    sender, receiver = ReliableChannel('robot_1'), ReliableChannel('robot_2')
    in_flight = []     # (ack arrival time, copy)
    for now in ticks(0.0, 5.0):
        if now <= 3.0:
            copy = send(library, sender, now)
            assert receiver.receive(copy, now + 0.004).deliver == copy
            in_flight.append((now + 1.0, copy))
        while in_flight and in_flight[0][0] <= now + 1e-9:
            ack(in_flight.pop(0)[1], now, sender)
        resend, failed = sender.poll(now)
        assert resend == [] and failed == [], now
    assert not in_flight and sender.next_deadline() == float('inf')
    assert sender.stats.resent == 0 and sender.stats.answered == 301 and receiver.stats.duplicates == 0


def test_a_copy_is_fast_retransmitted_once_a_later_copy_is_answered(library):
    policy = RetryPolicy(reorder_window_s=0.05)
    sender = ReliableChannel('robot_1', policy)
    lost = send(library, sender, 0.0)                    # the link loses it
    close = send(library, sender, 0.06)                  # within the reorder window of the proof: not suspected
    proof = send(library, sender, 0.1)
    ack(proof, 0.11, sender)
    assert sender.poll(0.159) == ([], [])                # the answer may have overtaken lost's: wait the window
    resend, failed = sender.poll(0.16)
    assert resend == [lost] and failed == [] and sender.stats.fast_resent == 1
    assert sender.awaiting(close.message_id) == ('robot_2',)
    ack(lost, 0.17, sender)
    ack(close, 0.18, sender)
    assert sender.next_deadline() == float('inf') and sender.stats.tail_resent == 0


def test_reordered_answers_within_the_window_cause_no_retransmission(library):
    sender = ReliableChannel('robot_1', RetryPolicy(reorder_window_s=0.05))
    first = send(library, sender, 0.0)
    second = send(library, sender, 0.1)
    ack(second, 0.12, sender)                            # the second batch's answer arrives first ...
    assert sender.poll(0.15) == ([], [])
    ack(first, 0.13 + 0.02, sender)                      # ... the first's 30 ms later
    for now in ticks(0.16, 5.0):
        assert sender.poll(now) == ([], [])
    assert sender.stats.resent == 0


def test_batches_are_compared_by_their_transmission_time(library):
    """Two copies queued 60 ms apart but sent in one batch: the answer to the later one proves
    nothing about the earlier one."""
    sender = ReliableChannel('robot_1', RetryPolicy(reorder_window_s=0.05))
    early = send(library, sender, 0.0)
    late = send(library, sender, 0.06)
    sender.transmitted('robot_2', [early.message_id, late.message_id], 0.06)
    ack(late, 0.07, sender)
    assert sender.poll(0.2) == ([], []) and sender.stats.fast_resent == 0


def test_a_tail_loss_is_re_sent_after_the_backed_off_timeout(library):
    policy = RetryPolicy(tail_timeout_s=1.0, min_timeout_s=1.0, backoff=2.0, max_timeout_s=4.0, peer_timeout_s=10.0)
    sender = ReliableChannel('robot_1', policy)
    ack(send(library, sender, 0.0), 0.01, sender)        # the peer is there (RTT 10 ms)
    tail = send(library, sender, 0.5)                    # lost; nothing is sent after it
    sends = {}
    for now in ticks(0.5, 6.0):
        for copy in sender.poll(now)[0]:
            sends[round(now, 2)] = copy
    assert sends == {1.5: tail, 3.5: tail}               # after 1 s, then 2 s more (backed off)
    assert sender.stats.tail_resent == 2 and sender.stats.fast_resent == 0
    ack(tail, 6.0, sender)
    assert sender.next_deadline() == float('inf') and sender.stats.undelivered == 0


def test_a_peer_is_given_up_only_after_peer_timeout_without_answers(library):
    """robot_2's link keeps losing one message while robot_2 answers the others: it is re-sent
    more often than any fixed retry budget allowed, and given up only after robot_2 has answered
    nothing for peer_timeout."""
    policy = RetryPolicy(reorder_window_s=0.05, tail_timeout_s=0.5, max_timeout_s=1.0, peer_timeout_s=3.0)
    sender = ReliableChannel('robot_1', policy)
    unlucky = send(library, sender, 0.0)
    failed_at = {}
    others = []
    last_answer = None
    for now in ticks(0.0, 10.0):
        if now < 5.0 and round(now / TICK) % 20 == 10:   # every 0.2 s another message, answered 20 ms later
            others.append((now + 0.02, send(library, sender, now)))
        while others and others[0][0] <= now + 1e-9 and now < 5.0:
            ack(others.pop(0)[1], now, sender)
            last_answer = now
        _, failed = sender.poll(now)
        for undelivered in failed:
            failed_at[undelivered.message.message_id] = now
    assert sender.stats.fast_resent >= 20                # the unlucky message, again and again
    assert last_answer == pytest.approx(4.92)
    assert failed_at[unlucky.message_id] == pytest.approx(last_answer + 3.0, abs=TICK + 1e-9)
    assert min(failed_at.values()) >= last_answer + 3.0 - 1e-9   # nothing given up while robot_2 answered
    assert sender.awaiting(unlucky.message_id) == () and sender.stats.undelivered == len(failed_at)


def test_a_silent_peer_is_given_up_and_fails_the_negotiation():
    policy = RetryPolicy(tail_timeout_s=0.5, max_timeout_s=1.0, peer_timeout_s=2.0)
    leader = ReliableChannel('robot_1', policy)
    negotiation, requests, _ = leader.propose('c', ('robot_1', 'robot_2'), 5.0, 0.0, 0.0)
    sends, failed = len(requests), []
    for now in ticks(0.0, 2.5):
        resend, gave_up = leader.poll(now)
        sends += len(resend)
        failed += gave_up
    assert [f.message.kind for f in failed] == [MessageKind.COMMIT_REQUEST] and failed[0].attempts == sends == 3
    assert negotiation.state(2.5) == 'failed' and negotiation.rejected == {'robot_2': 'no answer'}


def test_time_this_robot_did_not_poll_is_not_counted_against_its_peers(library):
    """The whole process stalled 8 s (one agent's long evaluation): the peer's answers wait unread
    in the inbox meanwhile, so the gap must not make robot_2 look silent; the answers read after
    the stall keep it alive, and only real silence afterwards gives it up."""
    policy = RetryPolicy(tail_timeout_s=0.5, max_timeout_s=1.0, peer_timeout_s=3.0, stall_s=0.5)
    sender = ReliableChannel('robot_1', policy)
    first = send(library, sender, 0.0)
    for now in ticks(0.0, 1.0):
        sender.poll(now)
    _, failed = sender.poll(9.0)                       # the next poll, 8 s later
    assert failed == [] and sender.stats.stalls == 1
    ack(first, 9.05, sender)                           # its answer, read from the inbox after the stall
    assert sender.awaiting(first.message_id) == ()
    second = send(library, sender, 9.1)
    failed_at = None
    for now in ticks(9.1, 13.0):                       # robot_2 really is silent now
        _, failed = sender.poll(now)
        if failed and failed_at is None:
            failed_at = now
    assert failed_at == pytest.approx(9.1 + 3.0, abs=TICK + 1e-9)   # silent since it owed the second
    assert sender.awaiting(second.message_id) == ()


def test_without_the_stall_rule_the_same_gap_would_give_the_peer_up(library):
    policy = RetryPolicy(tail_timeout_s=0.5, max_timeout_s=1.0, peer_timeout_s=3.0, stall_s=10.0)
    sender = ReliableChannel('robot_1', policy)
    first = send(library, sender, 0.0)
    for now in ticks(0.0, 1.0):
        sender.poll(now)
    _, failed = sender.poll(9.0)
    assert [f.message.message_id for f in failed] == [first.message_id] and sender.stats.stalls == 0


def test_commit_messages_are_handed_to_the_agent_before_queued_offers(library):
    """A helper's inbox holds a burst of offers when its leader's COMMIT_REQUEST and a RELEASE
    arrive: the agent gets the negotiation messages first, then the offers in arrival order."""
    helper = ReliableChannel('robot_2')
    queue: InboxQueue = InboxQueue()
    asked = request(library, sender='robot_2', message_id=1)
    offers = []
    for k in range(5):
        offer = offer_message(OfferSummary('robot_3', asked.request.label,
                                           asked.request.label.substitute({asked.request.label.variables[0]:
                                                                           Entity('robot_3', robot=True)}),
                                           1.0, ('robot_3',)), 100 + k, asked)
        offers.append(offer)
    commit = commit_request_message('robot_1', 7, 'robot_2', 'robot_1/7', ('robot_1', 'robot_2'), 9.0, 0.0)
    release = release_message('robot_3', 200, 'robot_2', 'robot_3/1')
    for now, message in enumerate(offers[:3] + [commit] + offers[3:] + [release]):
        received = helper.receive(message, float(now))
        assert [r.kind for r in received.replies] in ([MessageKind.ACK], [MessageKind.COMMIT_ACCEPT])
        queue.put(received.deliver, received)
    order = []
    while (entry := queue.pop()) is not None:
        order.append(entry[0])
    assert order == [commit, release] + offers and len(queue) == 0
    assert helper.ledger.holds('robot_1/7', 'robot_1', 8.0)


def lossy_exchange(library, lazy, seed, policy=None):
    """A sender talks to two peers for 4 s over a link that loses a third of the copies and
    answers after 5-300 ms, polled every 10 ms: eagerly (``poll`` at every tick) or lazily
    (``poll`` only from ``poll_due`` on, ``listen`` before, as the ROS channel does). Returns every
    re-send and give-up with its time, and how many polls walked the peers."""
    import random
    rng = random.Random(seed)
    sender = ReliableChannel('robot_1', policy)
    receivers = {name: ReliableChannel(name, policy) for name in ('robot_2', 'robot_3')}
    answers = []   # (arrival at the sender, ack)
    events, polls = [], 0

    def transmit(copies, now):
        for copy in copies:
            sender.transmitted(copy.receiver, [copy.message_id], now)
            if rng.random() < 1 / 3:
                continue   # lost
            received = receivers[copy.receiver].receive(copy, now)
            answers.extend((now + rng.uniform(0.005, 0.3), reply) for reply in received.replies)

    for now in ticks(0.0, 12.0):
        if now <= 4.0 and rng.random() < 0.3:
            message = request(library, message_id=sender.new_id())
            transmit(sender.send(message, now, [rng.choice(sorted(receivers))]), now)
        answers.sort(key=lambda entry: entry[0])
        while answers and answers[0][0] <= now + 1e-9:
            sender.receive(answers.pop(0)[1], now)
        if lazy and now < sender.poll_due():
            sender.listen(now)
            continue
        polls += 1
        resend, failed = sender.poll(now)
        events += [(round(now, 3), 'resend', copy.receiver, copy.message_id) for copy in resend]
        events += [(round(now, 3), 'failed', gone.receiver, gone.message.message_id) for gone in failed]
        transmit(resend, now)
    return events, polls, sender


@pytest.mark.parametrize('seed', range(6))
def test_polling_only_when_something_can_be_due_resends_the_same_copies_at_the_same_times(library, seed):
    eager, eager_polls, _ = lossy_exchange(library, lazy=False, seed=seed)
    lazy, lazy_polls, sender = lossy_exchange(library, lazy=True, seed=seed)
    assert lazy == eager and any(kind == 'resend' for _, kind, _, _ in eager)
    assert lazy_polls < eager_polls / 3
    assert sender.poll_due() <= sender.next_deadline() and not sender.has_pending()


def test_poll_due_never_passes_a_deadline_a_change_creates(library):
    policy = RetryPolicy(reorder_window_s=0.05)
    sender = ReliableChannel('robot_1', policy)
    assert sender.poll(0.0) == ([], []) and sender.poll_due() == float('inf')   # nothing pending
    first = send(library, sender, 1.0)
    assert 1.0 < sender.poll_due() <= sender.next_deadline()
    assert sender.poll(1.001) == ([], []) and sender.poll_due() == sender.next_deadline()
    second = send(library, sender, 1.2)
    sender.transmitted('robot_2', [second.message_id], 1.2)
    ack(second, 1.3, sender)   # proves ``first`` lost: re-sent reorder_window_s later
    assert sender.poll_due() <= 1.35 and sender.next_deadline() == pytest.approx(1.35)
    assert sender.poll(1.351)[0] == [first]
