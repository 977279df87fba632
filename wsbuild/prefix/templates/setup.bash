@HEADER@
@ABSPATH@
# a bash script is able to determine its own path
_wsb_setup_abspath "${BASH_SOURCE[0]}/.."
_wsb_setup_prefix="$_wsb_setup_abspath_result"
unset -f _wsb_setup_abspath
unset _wsb_setup_abspath_result

@FUNCTIONS@
@UNDERLAYS@
# source this prefix
_wsb_setup_source "$_wsb_setup_prefix" "$_wsb_setup_prefix"

unset -f _wsb_setup_prepend _wsb_setup_source
unset _wsb_setup_prefix
unset COLCON_CURRENT_PREFIX
