@HEADER@
# a zsh script is able to determine its own path
_wsb_setup_prefix="${${(%):-%N}:a:h}"

@FUNCTIONS@
@UNDERLAYS@
# source this prefix
_wsb_setup_source "$_wsb_setup_prefix" "$_wsb_setup_prefix"

unset -f _wsb_setup_prepend _wsb_setup_source
unset _wsb_setup_prefix
unset COLCON_CURRENT_PREFIX
