"""The two caches of a robot's reasoning, shared by the node's agent and the in-process search.

Both :class:`~.agent.SchemaAgent` (one robot, the node's) and :class:`~.coalition_search.CoalitionSearch`
(a whole team in one process, the core experiments and ``scripts/bench coalition``) instantiate
potential solutions again and again with the offers received so far, and ask again and again
whether an instance answers a request label. Two memos make that cheap without changing any
result (they are pure functions of what they are keyed on):

* :class:`OfferBook` -- the offers received per request label, and the *view* the reasoner
  instantiates with (request label -> offers): the same dict object until an offer is added or the
  book is cleared, and in it each label's list the same list object until an offer of *that* label
  is added. :meth:`~.coalition.RobotReasoner.local_coalition_solutions` keeps a leaf's candidate
  list and index for as long as it is given the same list (or readings) object, so every
  evaluation reuses them until an offer of that leaf's label arrives -- not only between two
  offers of any label.
* :class:`AnswerMemo` -- :func:`~.requests.answers_request` remembered per (instance, label): the
  same few hundred pairs come up at every serve.

Before they lived in the agent only, and the search rebuilt the view at every evaluation and
re-derived every answer test (12-31 % of its CPU in the benchmark's team searches).
"""
from __future__ import annotations

from typing import Callable, Generic, Hashable, Iterator, TypeVar

from .coalition_solution import InformationOffer
from .information import InformationInstance
from .requests import answers_request

Entry = TypeVar('Entry')


class OfferBook(Generic[Entry]):
    """Offers per request label, keyed ``(provider, instance)``; :meth:`view` is memoised.

    ``offer_of(entry)`` is the :class:`~.coalition_solution.InformationOffer` an entry stands for
    (the agent keeps ``(offer, members)``, the search the offer itself)."""

    def __init__(self, offer_of: Callable[[Entry], InformationOffer] = lambda entry: entry):  # type: ignore[assignment,return-value]
        self._offer_of = offer_of
        self._entries: dict[InformationInstance, dict[Hashable, Entry]] = {}
        #: label -> its offers as last listed; labels with an offer added since (ordered: no set)
        self._lists: dict[InformationInstance, list[InformationOffer]] = {}
        self._changed: dict[InformationInstance, None] = {}
        self._view: dict[InformationInstance, list[InformationOffer]] | None = None

    def get(self, label: InformationInstance, key: Hashable) -> Entry | None:
        """The entry kept for ``key`` under request ``label`` (None: none)."""
        return self._entries.get(label, {}).get(key)

    def put(self, label: InformationInstance, key: Hashable, entry: Entry) -> None:
        """Keep ``entry`` (replacing the one of the same key); the view changes."""
        self._entries.setdefault(label, {})[key] = entry
        self._changed[label] = None
        self._view = None

    def clear(self) -> None:
        self._entries.clear()
        self._lists.clear()
        self._changed.clear()
        self._view = None

    def labels(self) -> Iterator[InformationInstance]:
        return iter(self._entries)

    def view(self) -> dict[InformationInstance, list[InformationOffer]]:
        """request label -> its offers in arrival order (replacements keep their place): the same
        object until :meth:`put` or :meth:`clear`, and each label's list the same object until an
        offer of that label is put -- never mutate them. Labels in the order of their first offer."""
        if self._view is None:
            offer_of = self._offer_of
            for label in self._changed:  # first offers in order: _lists keeps the labels' first-offer order
                self._lists[label] = [offer_of(entry) for entry in self._entries[label].values()]
            self._changed.clear()
            self._view = dict(self._lists)
        return self._view


class AnswerMemo:
    """:func:`~.requests.answers_request` remembered per (instance, request label)."""

    def __init__(self) -> None:
        self._known: dict[tuple[InformationInstance, InformationInstance], bool] = {}

    def __call__(self, answer: InformationInstance, label: InformationInstance) -> bool:
        key = (answer, label)
        known = self._known.get(key)
        if known is None:
            known = self._known[key] = answers_request(answer, label)
        return known

    def __len__(self) -> int:
        return len(self._known)


__all__ = ['AnswerMemo', 'OfferBook']
