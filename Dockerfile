# Debian 12 image that builds mound-survey and runs its tests.
#   docker build -t mound-survey .
#   docker run --rm -v "$PWD/../shared:/src/shared:ro" mound-survey
# The tests read ../shared/data (beside the project), hence the mount at /src/shared.
FROM debian:12
ENV DEBIAN_FRONTEND=noninteractive
WORKDIR /src/mound-survey
COPY tools/setup.sh tools/setup.sh
COPY python/requirements.txt python/requirements.txt
RUN bash tools/setup.sh && rm -rf /var/lib/apt/lists/*
COPY . .
RUN make build
CMD ["make", "test"]
