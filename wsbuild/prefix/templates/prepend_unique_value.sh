# function to prepend a value to a variable
# which uses colons as separators
# duplicates (moved to the front) as well as empty entries are removed
# first argument: the name of the result variable
# second argument: the value to be prepended
# (no word splitting, so it behaves the same in sh, bash and zsh)
_colcon_prepend_unique_value() {
  case "$1" in
    ''|[!A-Za-z_]*|*[!A-Za-z0-9_]*) echo "invalid variable name: '$1'" 1>&2; return 1 ;;
  esac
  eval "_colcon_prepend_unique_value_rest=\${$1-}"
  _colcon_prepend_unique_value_all="$2"
  while [ -n "$_colcon_prepend_unique_value_rest" ]; do
    case "$_colcon_prepend_unique_value_rest" in
      *:*)
        _colcon_prepend_unique_value_item="${_colcon_prepend_unique_value_rest%%:*}"
        _colcon_prepend_unique_value_rest="${_colcon_prepend_unique_value_rest#*:}"
        ;;
      *)
        _colcon_prepend_unique_value_item="$_colcon_prepend_unique_value_rest"
        _colcon_prepend_unique_value_rest=
        ;;
    esac
    if [ -n "$_colcon_prepend_unique_value_item" ] && [ "$_colcon_prepend_unique_value_item" != "$2" ]; then
      _colcon_prepend_unique_value_all="$_colcon_prepend_unique_value_all:$_colcon_prepend_unique_value_item"
    fi
  done
  export "$1=$_colcon_prepend_unique_value_all"
  unset _colcon_prepend_unique_value_rest _colcon_prepend_unique_value_all _colcon_prepend_unique_value_item
}
