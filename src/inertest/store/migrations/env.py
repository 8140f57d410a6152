"""Alembic environment: migrations run on the connection inertest passes in."""

from alembic import context

from inertest.store.schema import Base

connection = context.config.attributes["connection"]
context.configure(connection=connection, target_metadata=Base.metadata, render_as_batch=True)
context.run_migrations()
