# Foresight service image: the API server and the worker run from it (see docker-compose.yaml).
#   docker build -t foresight .
#   docker run --rm -p 8000:8000 -v foresight-data:/data foresight foresight up --host 0.0.0.0
FROM python:3.11-slim

ENV PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    FORESIGHT_DATA_DIR=/data \
    FORESIGHT_STORE=/data/store

WORKDIR /app
# CPU build of torch first (as the Makefile does), so the resolver never pulls a CUDA build.
RUN pip install --index-url https://download.pytorch.org/whl/cpu torch==2.13.0

COPY pyproject.toml setup.py README.md alembic.ini ./
COPY foresight foresight
COPY core core
COPY api api
COPY worker worker
COPY store store
COPY cli cli
COPY migrations migrations
COPY configs configs
COPY model model
# The wheel carries configs/, model/, migrations/, templates and static files as package data.
RUN pip install '.[server,postgres,train,ray]' \
    && useradd --create-home --uid 1000 foresight \
    && mkdir -p /data/store && chown -R foresight /data
USER foresight
VOLUME ["/data"]
EXPOSE 8000
HEALTHCHECK --interval=10s --timeout=3s --start-period=20s \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/healthz', timeout=2)"
CMD ["foresight", "serve", "--host", "0.0.0.0", "--port", "8000"]
