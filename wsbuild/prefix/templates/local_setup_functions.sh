# _wsb_ls_prepend (_wsb_ls_append) NAME "$NAME" VALUE...: put the VALUEs, which are
# distinct and in their final order, in front of (behind) the colon-separated variable NAME,
# skipping those it already holds. All VALUEs lie in this prefix: unless the variable
# mentions the prefix (sourced before), none can be there and they are joined unchecked.
# The _checked variants take values from anywhere and always check.
_wsb_ls_prepend() {
  _wsb_ls_name="$1"
  _wsb_ls_old="$2"
  shift 2
  case ":$_wsb_ls_old:" in
    *":$_wsb_ls_prefix"[/:]*) _wsb_ls_filter "$@" ;;
    *) local IFS=:; _wsb_ls_new="$*" ;;
  esac
  export "$_wsb_ls_name=$_wsb_ls_new${_wsb_ls_old:+${_wsb_ls_new:+:}$_wsb_ls_old}"
}
_wsb_ls_append() {
  _wsb_ls_name="$1"
  _wsb_ls_old="$2"
  shift 2
  case ":$_wsb_ls_old:" in
    *":$_wsb_ls_prefix"[/:]*) _wsb_ls_filter "$@" ;;
    *) local IFS=:; _wsb_ls_new="$*" ;;
  esac
  export "$_wsb_ls_name=$_wsb_ls_old${_wsb_ls_new:+${_wsb_ls_old:+:}$_wsb_ls_new}"
}
_wsb_ls_prepend_checked() {
  _wsb_ls_name="$1"
  _wsb_ls_old="$2"
  shift 2
  _wsb_ls_filter "$@"
  export "$_wsb_ls_name=$_wsb_ls_new${_wsb_ls_old:+${_wsb_ls_new:+:}$_wsb_ls_old}"
}
_wsb_ls_append_checked() {
  _wsb_ls_name="$1"
  _wsb_ls_old="$2"
  shift 2
  _wsb_ls_filter "$@"
  export "$_wsb_ls_name=$_wsb_ls_old${_wsb_ls_new:+${_wsb_ls_old:+:}$_wsb_ls_new}"
}
# set _wsb_ls_new to the values $1... that $_wsb_ls_old does not hold, colon-separated
_wsb_ls_filter() {
  local IFS=:
  _wsb_ls_new=
  # sourcing the same prefix again finds all of them in a row: one check suffices
  case ":$_wsb_ls_old:" in
    *":$*:"*) return ;;
  esac
  for _wsb_ls_value in "$@"; do
    case ":$_wsb_ls_old:" in
      *":$_wsb_ls_value:"*) ;;
      *) _wsb_ls_new="${_wsb_ls_new:+$_wsb_ls_new:}$_wsb_ls_value" ;;
    esac
  done
}
# source a package script that comes without a .dsv description
_wsb_ls_source() {
  if [ -f "$1" ]; then
    if [ -n "${COLCON_TRACE:-}" ]; then
      echo "# . \"$1\""
    fi
    . "$1"
  else
    echo "not found: \"$1\"" 1>&2
  fi
}
