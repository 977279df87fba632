# set @FUNC@_result to "$1" made absolute against $PWD with "." and ".." removed
# lexically: what `cd "$1" && pwd` prints, without starting a subshell
@FUNC@() {
  local _rest="$1" _out="" _part
  case "$_rest" in
    /*) ;;
    *) _rest="$PWD/$_rest" ;;
  esac
  while [ -n "$_rest" ]; do
    case "$_rest" in
      */*) _part="${_rest%%/*}"; _rest="${_rest#*/}" ;;
      *) _part="$_rest"; _rest="" ;;
    esac
    case "$_part" in
      ''|.) ;;
      ..) _out="${_out%/*}" ;;
      *) _out="$_out/$_part" ;;
    esac
  done
  @FUNC@_result="${_out:-/}"
}
