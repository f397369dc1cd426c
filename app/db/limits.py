"""The largest values the tables' integer columns hold on every backend, where user input
is checked against them (PostgreSQL's int4; SQLite would take more). Kept apart from the
engines so that the CLI declares its options' ranges without importing SQLAlchemy."""

#: the largest id an ``Integer`` primary key holds
MAX_ROW_ID = 2**31 - 1
#: the largest world seed the graphs' integer column holds
MAX_WORLD = 2**31 - 1
