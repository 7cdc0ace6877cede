# One image for the server and the workers of a lab.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1
WORKDIR /app

# espeak-ng: the wizard's typed sentences in the actor's synthetic voice (docs/getting-started.md, "The two
# commands"); the server checks for it at start-up and shows it on the console.
RUN apt-get update && apt-get install --no-install-recommends -y espeak-ng \
    && rm -rf /var/lib/apt/lists/*

COPY pyproject.toml README.md ./
COPY chameleons ./chameleons
COPY prompts ./prompts
RUN pip install --no-cache-dir . \
    && useradd --create-home --uid 1000 chameleons \
    && mkdir -p /data && chown chameleons /data

USER chameleons
ENV CHAMELEONS_DATA_DIR=/data \
    CHAMELEONS_PROMPTS_DIR=/app/prompts
EXPOSE 8000 5555 5556 11111/udp 19977
CMD ["chameleons", "serve", "--host", "0.0.0.0"]
