"""HTTP routes, one module per resource; each route is thin: parse, call a service (which
writes, if it writes, in one transaction of the request's session), answer."""
