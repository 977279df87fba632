@HEADER@
# since a plain shell script can't determine its own path when being sourced
# either use the provided COLCON_CURRENT_PREFIX
# or fall back to the build time prefix (if it exists)
_wsb_setup_prefix=@BUILD_PREFIX@
if [ -n "${COLCON_CURRENT_PREFIX:-}" ]; then
  _wsb_setup_prefix="$COLCON_CURRENT_PREFIX"
elif [ ! -d "$_wsb_setup_prefix" ]; then
  echo "The build time path \"$_wsb_setup_prefix\" doesn't exist. Either source a script for a different shell or set the environment variable \"COLCON_CURRENT_PREFIX\" explicitly." 1>&2
  unset _wsb_setup_prefix
  return 1
fi

@FUNCTIONS@
@UNDERLAYS@
# source this prefix
_wsb_setup_source "$_wsb_setup_prefix" "$_wsb_setup_prefix"

unset -f _wsb_setup_prepend _wsb_setup_source
unset _wsb_setup_prefix
unset COLCON_CURRENT_PREFIX
