#!/usr/bin/env bash
# Installs every build and test dependency of kgd from Debian 12 packages.
# Idempotent and non-interactive; needs root (or sudo) for apt-get.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  libeigen3-dev            # dense/sparse linear algebra for the FEM
  libsuitesparse-dev       # CHOLMOD supernodal sparse Cholesky
  libopenblas-dev          # BLAS/LAPACK behind CHOLMOD's supernodal kernels
  libnanoflann-dev         # k-d tree for the body field's neighbour search
  libcli11-dev             # command-line parsing for the kgd CLI
  nlohmann-json3-dev       # scene files and --json output
  libhdf5-dev              # design files: the history of a design job (meshes, designs, positions)
  libsqlite3-dev           # the service's job queue and iteration metrics (server/)
  libprotobuf-dev protobuf-compiler   # the kgd.v1 schema (proto/)
  libgrpc++-dev protobuf-compiler-grpc  # the design service (gRPC server, workers, CLI)
  libgtest-dev libgmock-dev  # unit and integration tests
  libbenchmark-dev         # benchmarks in bench/
  libcpp-httplib-dev       # the HTTP door of the service (JSON API, Server-Sent Events, the web page)
  libcgal-dev              # pattern pieces: least-squares conformal maps (Surface_mesh_parameterization)
  libpng-dev               # the cut sheets' PNG previews
  prometheus-cpp-dev       # the service's figures at /metrics (Prometheus text format)
  openssl                  # deploy/make-secrets.sh; the tests' throwaway certificate authority
  python3 python3-yaml     # tests/deploy/deploy_check.py reads the compose file and the manifests
  fiu-utils                # the storage fault tests and `make faults`: libfiu's POSIX preload fails writes, fsyncs, opens
  faketime                 # tests/time_and_network_test: libfaketime steps kgd-server's wall clock an hour forward and back
)

# --browser: also Debian's chromium, for the web page's browser tests (`make test` passes it).
# --images:  also buildah and debootstrap, which build and run deploy/'s images (`make images`).
# --no-npm:  the Debian packages only, not the npm libraries (an image's build stage, which has no
#            sources yet when it installs the packages).
BROWSER=0 NPM=1
for arg in "$@"; do
  case "$arg" in
    --browser) BROWSER=1 ;;
    --images) PACKAGES+=(buildah debootstrap) ;;
    --no-npm) NPM=0 ;;
    *) echo "setup: unknown option $arg (--browser, --images, --no-npm)" >&2; exit 2 ;;
  esac
done
[ $BROWSER -eq 1 ] && PACKAGES+=(chromium)
# Node.js and npm fetch the web page's libraries (client/web/package-lock.json); a machine that has
# them (e.g. from NodeSource) keeps its own.
command -v npm > /dev/null || PACKAGES+=(nodejs npm)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
else
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The tests' Node.js libraries (playwright-core, kubernetes-models) need Node.js 20 or newer; Debian 12's
# own nodejs is 18. For the tests (--browser), an older Node.js gets Node.js 20 beside it from the npm
# registry's node-linux-<arch> package, linked as /usr/local/bin/node. The web page itself does not need
# it: without --browser an older Node.js installs the page's libraries only.
NODE_VERSION=20.20.2
node_major() { node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0; }
NODE_MAJOR=$(node_major)
if [ "$NODE_MAJOR" -lt 20 ] && [ $BROWSER -eq 1 ]; then
  case "$(uname -m)" in x86_64) NODE_ARCH=x64 ;; aarch64) NODE_ARCH=arm64 ;; *) NODE_ARCH=unknown ;; esac
  echo "setup: Node.js $(node --version 2>/dev/null || echo '(none)') is older than 20: installing Node.js $NODE_VERSION (npm package node-linux-$NODE_ARCH) as /usr/local/bin/node"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  NODE_BIN=/usr/local/lib/kgd-node/node_modules/node-linux-$NODE_ARCH/bin/node
  $SUDO npm install --prefix /usr/local/lib/kgd-node --no-save --no-audit --no-fund --loglevel=warn "node-linux-$NODE_ARCH@$NODE_VERSION" || true
  if [ -x "$NODE_BIN" ]; then
    $SUDO ln -sf "$NODE_BIN" /usr/local/bin/node
    hash -r
  fi
  NODE_MAJOR=$(node_major)
  if [ "$NODE_MAJOR" -lt 20 ]; then
    echo "setup: could not install Node.js 20, which the tests' playwright-core and kubernetes-models need." >&2
    echo "       Install Node.js 20 or newer (Debian 13's nodejs, or NodeSource's nodejs 20 for Debian 12) so that" >&2
    echo "       'node' on the PATH is that one, then run this again. make demo works with the Node.js you have." >&2
    exit 1
  fi
fi
NPM_OMIT=""
if [ "$NODE_MAJOR" -lt 20 ]; then
  echo "setup: Node.js $(node --version 2>/dev/null) is older than 20: installing the web page's libraries only (make test needs Node.js 20)"
  NPM_OMIT="--omit=dev"
fi

[ $NPM -eq 1 ] || exit 0

# The web page's libraries (three.js, uPlot) and the browser tests' driver (playwright-core), exactly as
# locked; again only when the lock file is newer than the installed tree.
# node_modules/.kgd-npm-omit says what the last install left out: a tree installed without the test
# libraries (an older Node.js, `make demo`) is installed again when they are wanted.
WEB="$(cd "$(dirname "$0")/.." && pwd)/client/web"
if [ ! -f "$WEB/node_modules/.package-lock.json" ] || [ "$WEB/package-lock.json" -nt "$WEB/node_modules/.package-lock.json" ] ||
   [ "$(cat "$WEB/node_modules/.kgd-npm-omit" 2>/dev/null || echo unknown)" != "$NPM_OMIT" ]; then
  echo "setup: npm ci ${NPM_OMIT:+$NPM_OMIT }in client/web"
  (cd "$WEB" && npm ci $NPM_OMIT --no-audit --no-fund --loglevel=warn)
  echo "$NPM_OMIT" > "$WEB/node_modules/.kgd-npm-omit"
else
  echo "setup: client/web/node_modules is up to date"
fi

# The Kubernetes schemas that tests/deploy validates the manifests against (kubernetes-models,
# @kubernetes-models/keda), exactly as locked; not in an image's build stage, which has no tests/.
DEPLOY_TESTS="$(cd "$(dirname "$0")/.." && pwd)/tests/deploy"
if [ ! -f "$DEPLOY_TESTS/package-lock.json" ] || [ "$NODE_MAJOR" -lt 20 ]; then
  :
elif [ ! -f "$DEPLOY_TESTS/node_modules/.package-lock.json" ] || [ "$DEPLOY_TESTS/package-lock.json" -nt "$DEPLOY_TESTS/node_modules/.package-lock.json" ]; then
  echo "setup: npm ci in tests/deploy"
  (cd "$DEPLOY_TESTS" && npm ci --no-audit --no-fund --loglevel=warn)
else
  echo "setup: tests/deploy/node_modules is up to date"
fi
