# The srg image of infra/compose.yaml: workers, beat, Flower and the API all run it.
# An editable install keeps alembic.ini and alembic/ beside the package, where
# `srg db upgrade` looks for them. (Not built in CI: no Docker engine there.)
FROM python:3.11-slim
WORKDIR /srv/srg
COPY pyproject.toml README.md alembic.ini ./
COPY alembic ./alembic
COPY app ./app
RUN pip install --no-cache-dir -e .
ENV SRG_VAR_DIR=/data
CMD ["srg", "--help"]
