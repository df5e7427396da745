#!/bin/bash
# Several "hosts" for real on one machine: two network namespaces joined by
# a veth pair, Open MPI ranks started in each from a hostfile, talking TCP
# only over that link; the outputs must equal the in-process engine's.
#
# Needs root (ip netns) and an orogen built with --features mpi.
# Usage: tools/mpi_netns.sh [path/to/orogen] [DEM]
# The two namespaces share the filesystem, as cluster nodes share a
# parallel filesystem.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${1:-target/debug/orogen}")
dem=$(realpath "${2:-../shared/data/pysheds_dem.tif}")
ns0=orogen-h0
ns1=orogen-h1
work=$(mktemp -d -t orogen-netns.XXXXXX)
cleanup() {
    ip netns del "$ns0" 2>/dev/null || true
    ip netns del "$ns1" 2>/dev/null || true
    rm -rf "$work"
}
trap cleanup EXIT
cleanup
work=$(mktemp -d -t orogen-netns.XXXXXX)

ip netns add "$ns0"
ip netns add "$ns1"
ip link add veth-h0 type veth peer name veth-h1
ip link set veth-h0 netns "$ns0"
ip link set veth-h1 netns "$ns1"
ip -n "$ns0" addr add 10.77.0.1/24 dev veth-h0
ip -n "$ns1" addr add 10.77.0.2/24 dev veth-h1
for n in "$ns0" "$ns1"; do
    ip -n "$n" link set lo up
done
ip -n "$ns0" link set veth-h0 up
ip -n "$ns1" link set veth-h1 up

# mpirun starts its daemon on a "remote" host through this agent instead of
# ssh: the host address picks the namespace.
cat >"$work/agent" <<EOF
#!/bin/sh
host="\$1"; shift
case "\$host" in
10.77.0.1) ns=$ns0 ;;
10.77.0.2) ns=$ns1 ;;
*) echo "agent: unknown host \$host" >&2; exit 1 ;;
esac
exec ip netns exec "\$ns" sh -c "\$*"
EOF
chmod +x "$work/agent"
printf '10.77.0.1 slots=1\n10.77.0.2 slots=1\n' >"$work/hosts"

mpi=(mpirun --allow-run-as-root --hostfile "$work/hosts" -n 2
    --mca plm_rsh_agent "$work/agent"
    --mca oob_tcp_if_include 10.77.0.0/24
    --mca btl tcp,self --mca btl_tcp_if_include 10.77.0.0/24)

mkdir -p "$work/local" "$work/mpi"
"$bin" fill "$dem" -o "$work/local/fill.tif" --tile 128 -q
"$bin" flow "$work/local/fill.tif" -o "$work/local/d8.tif" --tile 128 -q
# Show where the ranks run: each rank's network namespace address.
ip netns exec "$ns0" "${mpi[@]}" sh -c 'echo "rank $OMPI_COMM_WORLD_RANK on $(ip -4 -o addr show | grep -o "10\.77\.0\.[0-9]*")"'
ip netns exec "$ns0" "${mpi[@]}" "$bin" fill "$dem" -o "$work/mpi/fill.tif" --tile 128 -q --engine mpi
ip netns exec "$ns0" "${mpi[@]}" "$bin" flow "$work/mpi/fill.tif" -o "$work/mpi/d8.tif" --tile 128 -q --engine mpi
fails=0
for f in fill.tif d8.tif; do
    if cmp -s "$work/local/$f" "$work/mpi/$f"; then
        echo "identical over TCP between namespaces: $f"
    else
        echo "DIFFER: $f"
        fails=$((fails + 1))
    fi
done
[ "$fails" = 0 ]
