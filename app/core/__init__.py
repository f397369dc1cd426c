"""The pure core: stdlib, numpy and scipy only. Nothing here opens a file, a session or a socket.

Five domains, each a package, each importing only those below it (pyproject.toml's import
contracts hold the order): ``evaluation`` (what players met), ``growth`` (the self-refining
loop), ``players`` (who plays and how they are modelled), ``liquid`` (the liquid's maths)
and ``graph`` (the state graph and what a game must give it). The words every domain
shares (errors, choices, names) sit here at the top.
"""
