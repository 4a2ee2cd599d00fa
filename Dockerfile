# Debian 12 image that builds mound-survey and runs its tests.
#   docker build -t mound-survey .
#   docker run --rm -v "$PWD/../shared:/src/shared:ro" mound-survey
# The tests read ../shared/data (beside the project), hence the mount at /src/shared.
FROM debian:12
ENV DEBIAN_FRONTEND=noninteractive
WORKDIR /src/mound-survey
# setup.sh hashes python/requirements.txt + pyproject.toml and installs the package
# editable, so pyproject.toml, the README it names and the whole python/ tree are needed
# at this step.
COPY tools/setup.sh tools/setup.sh
COPY pyproject.toml README.md ./
COPY python/ python/
RUN bash tools/setup.sh && rm -rf /var/lib/apt/lists/*
COPY . .
RUN make build
CMD ["make", "test"]
