"""The field types every link model shares: strict models, seconds and their bounds."""

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

MAX_DELAY_S = 600.0


class StrictModel(BaseModel):
    model_config = ConfigDict(allow_inf_nan=False, extra="forbid", strict=True)


Seconds = Annotated[float, Field(ge=0.0, le=MAX_DELAY_S)]
