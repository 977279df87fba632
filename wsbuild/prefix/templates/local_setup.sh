@HEADER@
# since a plain shell script can't determine its own path when being sourced
# either use the provided COLCON_CURRENT_PREFIX
# or fall back to the build time prefix (if it exists)
_wsb_ls_prefix=@BUILD_PREFIX@
if [ -n "${COLCON_CURRENT_PREFIX:-}" ]; then
  _wsb_ls_prefix="$COLCON_CURRENT_PREFIX"
elif [ ! -d "$_wsb_ls_prefix" ]; then
  echo "The build time path \"$_wsb_ls_prefix\" doesn't exist. Either source a script for a different shell or set the environment variable \"COLCON_CURRENT_PREFIX\" explicitly." 1>&2
  unset _wsb_ls_prefix
  return 1
fi

@FUNCTIONS@
@BODY@
unset -f _wsb_ls_prepend _wsb_ls_append _wsb_ls_prepend_checked _wsb_ls_append_checked _wsb_ls_filter _wsb_ls_source
unset _wsb_ls_prefix _wsb_ls_name _wsb_ls_old _wsb_ls_new _wsb_ls_value
