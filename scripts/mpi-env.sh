# Sourced by the scripts: lets Open MPI run as root (containers, CI) and start more ranks
# than cores, as the two-core CI machines need.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
# One node: Open MPI's shared-memory pml (ob1) named, so that its default selection does not
# first probe the other pmls (UCX cannot be selected on these machines and is skipped after the
# probing): about 0.2 s of every launch here (0.37-0.45 s against 0.14-0.24 s for an empty MPI
# program on two ranks). A setting of the caller's own (a cluster's interconnect) is kept.
export OMPI_MCA_pml="${OMPI_MCA_pml:-ob1}"
