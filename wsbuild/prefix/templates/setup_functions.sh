# prepend the value $3 to the colon-separated variable named $1, whose current value is $2,
# unless it is already there
_wsb_setup_prepend() {
  case ":$2:" in
    *":$3:"*) ;;
    ::) export "$1=$3" ;;
    *) export "$1=$3:$2" ;;
  esac
}
# source local_setup.@EXT@ of the prefix $1 found in the directory $2 (or local_setup.sh:
# a workspace may have been built for sh only)
_wsb_setup_source() {
  COLCON_CURRENT_PREFIX="$1"
  # colcon's and ament's scripts read unset variables: let them, then restore `set -u`
  case $- in
    *u*) _wsb_setup_nounset=1; set +u ;;
    *) _wsb_setup_nounset= ;;
  esac
  if [ -f "$2/local_setup.@EXT@" ]; then
    if [ -n "${COLCON_TRACE:-}" ]; then
      echo "# . \"$2/local_setup.@EXT@\""
    fi
    . "$2/local_setup.@EXT@"
  elif [ -f "$2/local_setup.sh" ]; then
    if [ -n "${COLCON_TRACE:-}" ]; then
      echo "# . \"$2/local_setup.sh\""
    fi
    . "$2/local_setup.sh"
  else
    echo "not found: \"$2/local_setup.@EXT@\"" 1>&2
  fi
  if [ -n "$_wsb_setup_nounset" ]; then
    set -u
  fi
  unset _wsb_setup_nounset
}
