"""The fast flow methods, one file per integrator class (:mod:`refimpl.flows.registry` finds them).

Every module here lists its instances in ``INTEGRATORS``; each is a
:class:`refimpl.flows.base.FixedStep` or :class:`refimpl.flows.base.Adaptive` subclass instance
declaring ``order``, ``applies(model)`` and owning ``integrate``. Adding an integrator: one new
module here (plus its order test; ``tests/test_flow_orders.py`` fits every fixed-step method of the
registry).
"""
