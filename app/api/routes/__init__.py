"""HTTP routes, one module per resource; each route is thin: parse, call the store, and
write (if it writes) in one :func:`~app.store.transactions.in_transaction`."""
