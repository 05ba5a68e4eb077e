# romams service image: API (uvicorn api.app:app), workers (celery -A worker.celery_app) and migrations (alembic).
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    MPLBACKEND=Agg \
    ROMAMS_DATA_DIR=/data

RUN apt-get update && apt-get install -y --no-install-recommends curl && rm -rf /var/lib/apt/lists/*

WORKDIR /app
COPY pyproject.toml README.md alembic.ini ./
COPY romams_core ./romams_core
COPY romams ./romams
COPY api ./api
COPY worker ./worker
COPY client ./client
COPY migrations ./migrations
RUN pip install . ./client 'flower>=2.0' && (pip install --no-deps 'pyNastran==1.4.1' cpylog || true)

RUN useradd --create-home --uid 1000 romams && mkdir -p /data && chown romams /data
USER romams
# the numba kernels (flutter tracker, DLM) compiled once into the image (site-packages is read-only to this user)
ENV NUMBA_CACHE_DIR=/home/romams/numba-cache
RUN python -c "from romams_core.flutter.newton_kernel import warm_up; warm_up()"
RUN python -c "from romams_core.aero.dlm_kernel import warm_up; warm_up()"
VOLUME ["/data"]
EXPOSE 8000
CMD ["uvicorn", "api.app:app", "--host", "0.0.0.0", "--port", "8000"]
