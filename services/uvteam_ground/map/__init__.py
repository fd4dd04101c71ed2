"""`uvteam map`: a local web app that shows the team live on a map (see :mod:`.server`).

``state`` (what is drawn, from bus messages; pure), ``tiles`` (offline basemaps), ``server`` (the
zenoh subscriptions, the HTTP server and its server-sent events, the command line) and ``static/``
(the page, its script and the vendored Leaflet).
"""
