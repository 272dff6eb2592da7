"""``contactrig console``: the bench session in a browser (a local web app over a folder of sessions).

``security`` (token, origin, files under the folder), ``runner`` (the acquisition child process and its state),
``child`` (``daq.acquire.acquire`` with the console's prompter), ``app`` (pages, API, server-sent events),
``server`` (binding and serving). Needs the optional extra ``console`` (Starlette, uvicorn).
"""
